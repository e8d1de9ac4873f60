"""hlcmp_drake.run.drake_driver (hlcmp sim-driver --drake-driver): the scenario's world behind
Drake's own simulated iiwa driver. Its statuses against the project's simulated driver's,
`hlcmp serve` against it in one process (lockstep) and in two over udpm:// in real time."""

import numpy as np
import pytest
from pydrake.lcm import DrakeLcm

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.io.iiwa_lcm import decode_status, encode_torque_command
from hlcmp_drake.run.drake_driver import DrakeDrivenWorld, lockstep_drake
from hlcmp_drake.run.serve import TorqueClient, lockstep
from hlcmp_drake.run.sim_driver import SimulatedIiwaDriver
from hlcmp_drake.worlds.arm import prepare


def _statuses(lcm, channel):
    received = []
    lcm.Subscribe(channel, received.append)
    return received


def test_the_project_driver_reports_what_drakes_driver_reports():
    """Both drivers from the start posture, the same constant torque command for 50 ms at
    1 ms: the same positions and velocities, and the same torque fields with Drake's
    signs (the joint torque with gravity compensation, negated; the external torque
    zero in free space)."""
    scenario, _ = load_scenario("insertion", ["iiwa_driver.period_s=0.001"])
    channel = scenario.iiwa_driver.status_channel
    command = np.array([2.0, -1.5, 1.0, -1.0, 0.5, -0.5, 0.2])

    drake_lcm = DrakeLcm("memq://")
    drake_statuses = _statuses(drake_lcm, channel)
    drake = DrakeDrivenWorld(scenario, drake_lcm, 0.001)
    # A command waiting before the start is applied from the first plant step.
    drake_lcm.Publish(
        scenario.iiwa_driver.command_channel, encode_torque_command(0, np.zeros(7), command)
    )
    drake.simulator.Initialize()
    drake.simulator.AdvanceTo(0.05)
    drake_lcm.HandleSubscriptions(0)

    ours_lcm = DrakeLcm("memq://")
    ours_statuses = _statuses(ours_lcm, channel)
    ours = SimulatedIiwaDriver(scenario, ours_lcm)
    ours.publish_status()
    for _ in range(50):
        ours.step(command)
        ours.publish_status()
    ours_lcm.HandleSubscriptions(0)

    assert len(drake_statuses) == len(ours_statuses) == 51
    for k in (0, 1, 50):
        theirs, mine = (decode_status(s[k], 7) for s in (drake_statuses, ours_statuses))
        assert mine.utime == theirs.utime == 1000 * k
        np.testing.assert_allclose(mine.position, theirs.position, atol=1e-12)
        np.testing.assert_allclose(mine.velocity, theirs.velocity, atol=1e-10)
        for field in ("torque_commanded", "torque_measured", "torque_external"):
            np.testing.assert_allclose(
                getattr(mine, field), getattr(theirs, field), atol=1e-9, err_msg=field
            )
    moved = decode_status(ours_statuses[50], 7)
    assert np.abs(moved.velocity).max() > 0.01  # the command moved the arm
    assert np.abs(moved.torque_commanded).max() > 10.0  # gravity compensation is in it


@pytest.mark.parametrize("period", [0.001, 0.005])
def test_drakes_driver_is_the_project_driver_with_a_command_one_plant_step_late(period):
    """The insertion's Hl-CMP served in lockstep by Drake's driver and by the project's with
    --command-delay 1: the same run, number for number. Drake's LCM subscriber takes a
    command in after the plant step that has begun when it came; the project's driver
    with no delay acts on it from its status on, and its runs then differ."""
    overrides = ["duration_s=0.3", f"iiwa_driver.period_s={period}"]
    scenario, _ = load_scenario("insertion", overrides)
    setup = prepare(scenario)
    runs = {}
    for name, delay in (("drake", None), ("delayed", 1), ("at_once", 0)):
        lcm = DrakeLcm("memq://")
        client = TorqueClient(scenario, "hlcmp", lcm, setup=setup)
        if delay is None:
            lockstep_drake(DrakeDrivenWorld(scenario, lcm, period), client, lcm)
        else:
            driver = SimulatedIiwaDriver(scenario, lcm, setup, command_delay_steps=delay)
            lockstep(driver, client, lcm)
        assert client.status == "ok" and client.missed_ticks == 0, client.stopped_because
        runs[name] = client.run_result()
    for series in ("x", "plant_state", "Ks", "v"):
        drake = runs["drake"].series[series]
        assert np.abs(runs["delayed"].series[series] - drake).max() <= 1e-12, series
    assert np.abs(runs["at_once"].series["x"] - runs["drake"].series["x"]).max() > 1e-7
