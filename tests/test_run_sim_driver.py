"""hlcmp_drake.run.sim_driver (hlcmp sim-driver): the simulated iiwa driver's start guard."""

import os
import random
import time

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


def test_both_drivers_abort_alike_when_no_command_comes():
    """With no client, the project's driver and Drake's both give up after their first
    command timeout (60 s by default) with the same reason (`hlcmp sim-driver` exits 4)."""
    from hlcmp_drake.run.drake_driver import DrakeDrivenWorld
    from hlcmp_drake.run.sim_driver import drive

    scenario, _ = load_scenario("insertion", ["duration_s=1.0"])
    lcm = DrakeLcm("memq://")
    with pytest.raises(DriverAbort, match=r"^no command on IIWA_COMMAND within 0.1 s$"):
        drive(SimulatedIiwaDriver(scenario, lcm), lcm, first_command_timeout_s=0.1)
    lcm = DrakeLcm("memq://")
    with pytest.raises(DriverAbort, match=r"^no command on IIWA_COMMAND within 0.1 s$"):
        DrakeDrivenWorld(scenario, lcm, 0.005).run(first_command_timeout_s=0.1)


def test_a_driver_waiting_for_its_first_command_keeps_no_core_busy():
    """Left waiting for a client (a minute by default), the driver sleeps in LCM's wait
    between its t = 0 statuses: it used to poll, a whole core for the wait. Its statuses
    still go out about once a period."""
    from hlcmp_drake.run.sim_driver import wait_for_first_command

    scenario, _ = load_scenario("insertion", ["duration_s=1.0"])
    group = f"239.255.{random.randint(1, 254)}.{random.randint(1, 254)}"
    lcm = DrakeLcm(f"udpm://{group}:{random.randint(20000, 60000)}?ttl=0")
    driver = SimulatedIiwaDriver(scenario, lcm)
    published = 0
    publish = driver.publish_status

    def counted():
        nonlocal published
        published += 1
        publish()

    driver.publish_status = counted
    before, wall = os.times(), time.perf_counter()
    with pytest.raises(DriverAbort, match="no command on IIWA_COMMAND within 0.5 s"):
        wait_for_first_command(driver, lcm, 0.5)
    after, wall = os.times(), time.perf_counter() - wall
    busy = (after.user + after.system - before.user - before.system) / wall
    assert busy < 0.3, f"{busy:.0%} of a core while waiting"
    assert 0.25 * wall / driver.period < published <= wall / driver.period + 1


def test_a_command_delay_is_checked_against_duration_only_when_there_is_one(monkeypatch):
    """Without --duration the driver runs until its client stops, not for the scenario's
    duration_s: a delay longer than duration_s was refused against a run length the driver
    never keeps. With --duration it must be shorter than that."""
    from hlcmp_drake.io.errors import InputError
    from hlcmp_drake.run.sim_driver import run_sim_driver

    class Opened(Exception):
        pass

    def open_lcm(url):
        raise Opened(url)

    monkeypatch.setattr("hlcmp_drake.run.sim_driver.open_lcm", open_lcm)
    url = "udpm://239.255.76.67:7667?ttl=0"
    with pytest.raises(Opened):  # past every check of its input: 100 s of delay
        run_sim_driver("insertion", url, command_delay_steps=100_000)
    with pytest.raises(InputError, match=r"^--command-delay 2000: 2 s of plant steps must be "):
        run_sim_driver("insertion", url, duration=2.0, command_delay_steps=2000)
