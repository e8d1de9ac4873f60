"""hlcmp_drake.run.sim_driver (hlcmp sim-driver): the simulated iiwa driver's start guard."""

import numpy as np
import pytest
from pydrake.lcm import DrakeLcm

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.io.iiwa_lcm import (
    encode_torque_command,
)
from hlcmp_drake.run.sim_driver import DriverAbort, SimulatedIiwaDriver


def test_the_driver_aborts_on_a_command_within_its_start_guard():
    scenario, _ = load_scenario("insertion", ["duration_s=1.0"])
    lcm = DrakeLcm("memq://")
    driver = SimulatedIiwaDriver(scenario, lcm)
    driver.publish_status()
    lcm.Publish(
        scenario.iiwa_driver.command_channel, encode_torque_command(0, np.zeros(7), np.zeros(7))
    )
    with pytest.raises(DriverAbort, match="within 0.25 s of the driver's first status"):
        lcm.HandleSubscriptions(0)
