"""hlcmp_drake.run.drake_driver (hlcmp sim-driver --drake-driver): the scenario's world behind
Drake's own simulated iiwa driver. Its statuses against the project's simulated driver's,
`hlcmp serve` against it in one process (lockstep) and in two over udpm:// in real time."""

import json
import random
import subprocess
import sys

import numpy as np
import pytest
from conftest import run_cli
from pydrake.lcm import DrakeLcm
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.lcm import LcmInterfaceSystem

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.io.iiwa_lcm import decode_status, encode_torque_command
from hlcmp_drake.run.drake_driver import DrakeDrivenWorld, lockstep_drake
from hlcmp_drake.run.serve import TorqueClient, lockstep, write_served
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


@pytest.mark.slow  # two drivers serve the insertion in lockstep (about 1.6-1.9 s)
@pytest.mark.parametrize("period", [0.001, 0.005])
def test_drakes_driver_is_the_project_driver_with_a_command_one_plant_step_late(period):
    """The insertion's Hl-CMP served in lockstep by Drake's driver and by the project's with
    --command-delay 1: the same run, number for number. Drake's LCM subscriber takes a
    command in after the plant step that has begun when it came; the project's driver
    with no delay acts on it from its status on, and its runs then differ."""
    overrides = [
        "duration_s=0.3",
        f"iiwa_driver.period_s={period}",
        "iiwa_driver.force_source=external_torque",  # Drake's driver has no wrist sensor
    ]
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
            summary = lockstep(driver, client, lcm)
            # the periods whose every plant step was still waiting out the delay
            waiting = delay // round(period / scenario.plant_config.time_step)
            assert summary.steps - summary.commanded_steps == waiting
        assert client.status == "ok" and client.missed_ticks == 0, client.stopped_because
        runs[name] = client.run_result()
    for series in ("x", "plant_state", "Ks", "v"):
        drake = runs["drake"].series[series]
        assert np.abs(runs["delayed"].series[series] - drake).max() <= 1e-12, series
    assert np.abs(runs["at_once"].series["x"] - runs["drake"].series["x"]).max() > 1e-7


# A served run in real time against Drake's driver, and the same run in lockstep with
# Drake's driver in this process (each command acting one plant step after its status):
# real time makes some commands later by more plant steps, and some statuses reach the
# client only with the next one (at most 1 % in a run that is "ok"). That jitter,
# emulated without a clock (`python scripts/jitter_tolerance.py`: each command 1 to 3
# plant steps late at random, 1 % of the statuses held back; 5 seeds; insertion, 3 s at
# 5 ms and 2 s at 1 ms, in free space), moved the metrics by at most 8.1 µm (position
# errors), 3.1e-5 N/m (learned stiffness) and 2.0e-4 N (feed-forward). These allow 2.5
# times that, or 5 %: the learned values are still near zero, so relative changes of
# them say nothing.
REAL_TIME_RTOL = 0.05
REAL_TIME_ATOL = {"_N_per_m": 1e-4, "_N": 5e-4, "_m": 2e-5, "_ratio_z": 0.05}


def _assert_close_to_lockstep(served, lockstep_metrics, where=""):
    if isinstance(lockstep_metrics, dict):
        assert served.keys() == lockstep_metrics.keys()
        for key in lockstep_metrics:
            _assert_close_to_lockstep(served[key], lockstep_metrics[key], f"{where}.{key}")
    elif isinstance(lockstep_metrics, float):
        metric = where.split(".")[1]
        atol = next(v for suffix, v in REAL_TIME_ATOL.items() if metric.endswith(suffix))
        assert served == pytest.approx(lockstep_metrics, rel=REAL_TIME_RTOL, abs=atol), where
    elif not where.endswith("evidence"):  # its millimetres are the numbers above, rounded
        assert served == lockstep_metrics, where


@pytest.mark.slow
@pytest.mark.parametrize("period, duration", [(0.005, 3.0), (0.001, 2.0)])
def test_served_in_real_time_against_drakes_own_driver(tmp_path, period, duration):
    """Drake's driver (5 ms: BuildIiwaControl as it is; 1 ms: its systems behind a 1 ms
    publisher) and hlcmp serve as two processes over udpm://, in real time: the period is
    measured, every status is answered or counted, the run is "degraded" (exit 5) exactly
    when more than 1 % of the ticks or 10 in a row were missed, and the metrics of an ok
    run are those of the same run in lockstep within the jitter's tolerance above. The runs
    end before the foam: in contact, the world behind Drake's driver does not keep real
    time on a 2-core machine (docs/iiwa.md)."""
    client, record = _served_against_drakes_driver(tmp_path / "served", period, duration)
    statuses = round(duration / period) + 1
    assert record["ticks"] + record["missed_ticks"] == statuses, record  # says why it stopped
    assert record["status_period_s"] == pytest.approx(period, rel=0.01)
    too_many = record["missed_ticks"] > 0.01 * statuses or record["longest_missed_run"] >= 10
    assert record["status"] == ("degraded" if too_many else "ok"), record
    assert client.returncode == (5 if too_many else 0), client.stderr
    # Whether the 5 ms run stays ok is a speed, measured on a quiet machine by
    # scripts/serve_latency.py (docs/iiwa.md), not asserted here: in the suite another
    # test worker shares the 2 cores and can hold the client past a status.
    if record["status"] != "ok":
        return  # the metrics of a degraded run are no measure of the jitter's effect

    scenario, _ = load_scenario("insertion", [f"duration_s={duration}", *_client_settings(period)])
    lcm = DrakeLcm("memq://")
    reference = TorqueClient(scenario, "hlcmp", lcm)
    lockstep_drake(DrakeDrivenWorld(scenario, lcm, period), reference, lcm)
    expected = write_served(reference, tmp_path / "lockstep", "memq://").metrics
    served = json.loads((tmp_path / "served" / "metrics.json").read_text())
    _assert_close_to_lockstep(served["controllers"]["hlcmp"], expected["controllers"]["hlcmp"])


def _client_settings(period):
    """The client's settings against Drake's driver: its status period, and the wrist
    force from the external torques (Drake's driver publishes no wrist sensor)."""
    return [f"iiwa_driver.period_s={period}", "iiwa_driver.force_source=external_torque"]


def _served_against_drakes_driver(out, period, duration):
    """`hlcmp sim-driver insertion --drake-driver` and `hlcmp serve insertion` as two
    processes on a udpm:// group of their own (239.255.77.x, apart from the project
    driver's tests), both started and stopped here; returns the client's completed
    process and serve.json."""
    url = f"udpm://239.255.77.{random.randint(1, 250)}:{random.randint(20000, 60000)}?ttl=0"
    cli = [sys.executable, "-m", "hlcmp_drake.cli"]
    driver = subprocess.Popen(
        [*cli, "sim-driver", "insertion", "--lcm", url, "--drake-driver", "--quiet"]
        + ["--status-period", str(period)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        sets = [a for key_value in _client_settings(period) for a in ("--set", key_value)]
        client = subprocess.run(
            [*cli, "serve", "insertion", "--lcm", url, "--duration", str(duration)]
            + ["--out", str(out), "--quiet", *sets],
            capture_output=True,
            text=True,
            timeout=300,
        )
        driver_out, driver_err = driver.communicate(timeout=60)
    finally:
        if driver.poll() is None:
            driver.kill()
            driver.communicate()
    assert driver.returncode == 0, driver_err
    assert "the client stopped" in driver_out, driver_out
    return client, json.loads((out / "serve.json").read_text())


def test_build_iiwa_control_publishes_every_5_ms_whatever_lcm_status_period_says():
    """Why Drake's driver as it is publishes every 5 ms (docs/iiwa.md): BuildIiwaControl
    makes its status publisher with kIiwaLcmStatusPeriod, and IiwaDriver.lcm_status_period
    set to 1 ms changes nothing in torque-only mode."""
    from pydrake.manipulation import BuildIiwaControl, IiwaDriver, kIiwaLcmStatusPeriod

    from hlcmp_drake.run.simulate import prepared_simulator
    from hlcmp_drake.worlds.arm import build_driven
    from hlcmp_drake.worlds.models import load_models

    scenario, _ = load_scenario("insertion")
    lcm = DrakeLcm("memq://")
    statuses = _statuses(lcm, "IIWA_STATUS")
    controller_plant = MultibodyPlant(0.0)
    load_models(controller_plant, scenario)
    config = IiwaDriver(control_mode="torque_only", lcm_status_period=0.001)

    def add_driver(builder, plant):
        builder.AddSystem(LcmInterfaceSystem(lcm))
        iiwa = plant.GetModelInstanceByName("iiwa")
        BuildIiwaControl(builder, lcm, plant, iiwa, config, controller_plant)

    built = build_driven(scenario, prepare(scenario), add_driver=add_driver)
    simulator = prepared_simulator(built, scenario)
    simulator.AdvanceTo(0.05)
    lcm.HandleSubscriptions(0)
    stamps = [decode_status(data, 7).utime for data in statuses]
    assert kIiwaLcmStatusPeriod == 0.005
    assert len(stamps) == 11 and np.all(np.abs(np.diff(stamps) - 5000) <= 1)


def test_the_drake_driver_command_runs_alone_to_its_duration():
    """hlcmp sim-driver --drake-driver with no client: it keeps real time to --duration,
    then exits 0 with its summary line (the statuses' period is measured by the client in
    the real-time test)."""
    url = f"udpm://239.255.77.{random.randint(1, 250)}:{random.randint(20000, 60000)}?ttl=0"
    result = run_cli(
        *("sim-driver", "insertion", "--lcm", url, "--drake-driver", "--quiet"),
        *("--status-period", "0.001", "--duration", "0.1"),
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith(
        "sim-driver (Drake's iiwa driver, status every 1 ms): 0 commands, 0.100 s simulated"
    )
    assert result.stdout.strip().endswith("reached --duration 0.1 s")
