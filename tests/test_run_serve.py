"""hlcmp_drake.run.serve (hlcmp serve, with hlcmp sim-driver): the served controller against
the simulated run (in one process over memq://, in two over udpm://), the watchdogs, and
bad serve input."""

import dataclasses as dc
import errno
import json
import os
import random
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from conftest import INSERTION_DEMO, assert_output_names, one_line_error, run_cli
from pydrake.lcm import DrakeLcm
from pydrake.multibody.tree import JacobianWrtVariable

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.iiwa_lcm import (
    IiwaStatus,
    encode_status,
    encode_wrench,
)
from hlcmp_drake.run import serve as serve_module
from hlcmp_drake.run.serve import (
    STOPPED,
    UNSAFE,
    TorqueClient,
    realtime_scheduling,
    serve,
    serve_scenario,
    served_priority,
    write_served,
)
from hlcmp_drake.run.sim_driver import SimulatedIiwaDriver
from hlcmp_drake.worlds.arm import prepare

# A served run evaluates the same functions on the same numbers as the simulated run
# (measured: equal to rounding), so its metrics must agree far inside this.
METRICS_RTOL = 1e-6


def hlcmp(*args):
    return subprocess.Popen(
        [sys.executable, "-m", "hlcmp_drake.cli", *map(str, args)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def serve_two_processes(tmp_path, driver_args, duration, client_codes=(0,), client_sets=()):
    """hlcmp sim-driver and hlcmp serve insertion as two processes on a udpm:// group of their
    own; the driver must exit 0, the client with one of `client_codes`. Returns the driver's
    output and serve.json."""
    sets = [a for key_value in client_sets for a in ("--set", key_value)]
    url = f"udpm://239.255.76.{random.randint(100, 250)}:{random.randint(20000, 60000)}?ttl=0"
    driver = hlcmp("sim-driver", "insertion", "--lcm", url, "--quiet", *driver_args)
    client = hlcmp(
        "serve",
        "insertion",
        "--lcm",
        url,
        "--duration",
        duration,
        "--out",
        tmp_path / "serve",
        "--quiet",
        "--set",
        "iiwa_driver.first_status_timeout_s=120",  # a driver may start slowly
        *sets,
    )
    client_out, client_err = client.communicate(timeout=300)
    driver_out, driver_err = driver.communicate(timeout=60)
    assert client.returncode in client_codes, client_err + client_out
    assert driver.returncode == 0, driver_err
    return driver_out, json.loads((tmp_path / "serve" / "serve.json").read_text())


def assert_metrics_match(served, simulated):
    """Every number of one controller's metrics, within METRICS_RTOL (and 1e-12 absolute)."""
    if isinstance(simulated, dict):
        assert served.keys() == simulated.keys()
        for key in simulated:
            assert_metrics_match(served[key], simulated[key])
    elif isinstance(simulated, list):  # per axis
        assert len(served) == len(simulated)
        for mine, theirs in zip(served, simulated):
            assert_metrics_match(mine, theirs)
    elif isinstance(simulated, (int, float)) and not isinstance(simulated, bool):
        assert served == pytest.approx(simulated, rel=METRICS_RTOL, abs=1e-12)
    else:
        assert served == simulated


@pytest.fixture(scope="module")
def served_insertion(tmp_path_factory):
    """The insertion's Hl-CMP served over memq:// to the simulated driver, the whole scenario."""
    out = tmp_path_factory.mktemp("served")
    return serve_scenario("insertion", "memq://", out)


@pytest.mark.slow
def test_served_hlcmp_matches_the_simulated_run(served_insertion, insertion_run):
    """One process, memq://: the served Hl-CMP drives the simulated insertion through the
    pierce and back; its metrics, θ and tip path are those of `hlcmp run insertion`."""
    result = served_insertion
    assert result.record["status"] == "ok", result.record["stopped_because"]
    assert result.record["missed_ticks"] == 0
    assert result.record["ticks"] == 9501
    simulated = json.loads((insertion_run / "metrics.json").read_text())["controllers"]["hlcmp"]
    served = json.loads((result.out_dir / "metrics.json").read_text())["controllers"]["hlcmp"]
    assert max(served["max_abs_force_N"].values()) > 5.0  # it went through the foam
    assert_metrics_match(served, simulated)
    logged = np.load(insertion_run / "timeseries.npz")
    np.testing.assert_allclose(result.run.t, logged["t"], atol=1e-12)
    for series in ("x", "f_ext", "Ks", "v", "plant_state"):
        reference = logged[f"hlcmp/{series}"]
        scale = max(1.0, np.abs(reference).max())
        assert np.abs(result.run.series[series] - reference).max() < 1e-9 * scale, series
    for written in ("timeseries.npz", "metrics.json", "serve.json", "recording.html"):
        assert (result.out_dir / written).is_file()


@pytest.mark.slow
def test_two_processes_over_udpm(tmp_path):
    """hlcmp sim-driver and hlcmp serve as two processes on udpm://...?ttl=0, as fast as the
    client answers: no tick missed, and the metrics of the same run simulated in-process."""
    # In lockstep the driver waits for every command: on a busy machine (the other test
    # worker) a status can come later than the real-time stale_status_s of 50 ms without
    # anything being wrong. That watchdog has its own test (test_a_stale_status_...).
    driver_out, record = serve_two_processes(
        tmp_path, [], 1.5, client_sets=["iiwa_driver.stale_status_s=2.0"]
    )
    assert "the client stopped answering at t = 1.501 s" in driver_out
    assert record["ticks"] == 1501 and record["missed_ticks"] == 0
    assert record["tick_us"]["p50"] > 0 and record["stopped_because"] == "served 1.5 s"

    from hlcmp_drake.experiments import experiment_of
    from hlcmp_drake.run.simulate import simulate
    from hlcmp_drake.worlds.build import diagram_factory

    scenario, _ = load_scenario("insertion", ["duration_s=1.5"])
    run = simulate(diagram_factory(scenario)("hlcmp"), scenario, "hlcmp")
    simulated = experiment_of(scenario).metrics_of(run, scenario.controllers["hlcmp"], scenario)
    served = json.loads((tmp_path / "serve" / "metrics.json").read_text())["controllers"]["hlcmp"]
    assert_metrics_match(served, json.loads(json.dumps(simulated)))


@pytest.mark.parametrize("number, name", [(signal.SIGINT, "Ctrl-C"), (signal.SIGTERM, "SIGTERM")])
def test_ctrl_c_or_sigterm_while_serving_stops_it_and_writes_what_was_served(
    tmp_path, monkeypatch, number, name
):
    """SIGINT or SIGTERM (`kill`, `timeout`) after the 100th tick: the client stops there,
    between two ticks, and the run up to then is written (serve.json says so); the command
    exits 130 as for any Ctrl-C. (SIGTERM ended it at once, writing nothing.)"""
    from hlcmp_drake.cli import main

    answer = TorqueClient._answer

    def answer_then_interrupt(self, *status_and_receipt):
        answer(self, *status_and_receipt)
        if self.ticks == 100:
            signal.raise_signal(number)

    monkeypatch.setattr(TorqueClient, "_answer", answer_then_interrupt)
    out = tmp_path / "serve"
    args = ["serve", "insertion", "--lcm", "memq://", "--duration", "1", "--quiet"]
    # Python's own handlers, as in a terminal: a pytest started in the background by a
    # shell without job control inherits SIGINT ignored, and Python then installs none.
    own = {signal.SIGINT: signal.default_int_handler, signal.SIGTERM: signal.SIG_DFL}
    before = {n: signal.signal(n, handler) for n, handler in own.items()}
    try:
        assert main([*args, "--out", str(out)]) == 130
        assert {n: signal.getsignal(n) for n in own} == own  # put back
    finally:
        for n, handler in before.items():
            signal.signal(n, handler)
    record = json.loads((out / "serve.json").read_text())
    assert record["status"] == "interrupted" and record["ticks"] == 100
    assert record["stopped_because"] == f"{name} at t = 0.099 s"
    assert json.loads((out / "metrics.json").read_text())["status"] == "interrupted"
    assert len(np.load(out / "timeseries.npz")["t"]) == 10  # logged at 100 Hz up to then


def test_a_stale_status_stops_the_commands(tmp_path, monkeypatch):
    """The driver goes quiet mid-run: the client stops commanding within stale_status_s and
    says so; no command follows."""
    scenario, _ = load_scenario("insertion", ["duration_s=1.0", "iiwa_driver.start_guard_s=0.001"])
    lcm = DrakeLcm("memq://")
    setup = prepare(scenario)
    client = TorqueClient(scenario, "hlcmp", lcm, setup=setup)
    driver = SimulatedIiwaDriver(scenario, lcm, setup)
    commands = []
    lcm.Subscribe(scenario.iiwa_driver.command_channel, commands.append)
    monkeypatch.setattr("hlcmp_drake.run.sim_driver.START_COMMAND_GUARD_S", 0.0)
    driver.publish_status()
    lcm.HandleSubscriptions(0)
    time.sleep(0.002)  # past the client's start guard
    for _ in range(50):
        driver.publish_status()
        lcm.HandleSubscriptions(0)
        client.poll()
        lcm.HandleSubscriptions(0)
        driver.step(driver.command[1])
    answered = len(commands)
    assert answered == 50 and not client.done
    serve(client, lcm, "memq://")  # no driver any more: returns when the watchdog stops it
    assert client.status == STOPPED
    assert client.stopped_because.startswith("no status for 50 ms (stale) at t = 0.049 s")
    assert len(commands) == answered
    result = write_served(client, tmp_path, "memq://")
    record = json.loads((tmp_path / "serve.json").read_text())
    assert record["status"] == "stopped" and "stale" in record["stopped_because"]
    assert result.metrics["status"] == "stopped" and len(result.run.t) == 5


def _client_fed_by_hand(scenario_overrides=(), controller="hlcmp"):
    scenario, _ = load_scenario(
        "insertion", ["duration_s=1.0", "iiwa_driver.start_guard_s=0.001", *scenario_overrides]
    )
    lcm = DrakeLcm("memq://")
    client = TorqueClient(scenario, controller, lcm)
    commands = []
    lcm.Subscribe(scenario.iiwa_driver.command_channel, commands.append)

    def send(utime, q, v=None, torque_external=None, wrench=True, also=()):
        zeros = np.zeros(7)
        if wrench and scenario.iiwa_driver.force_source == "wrist_sensor":  # reading nothing
            lcm.Publish(
                scenario.iiwa_driver.wrist_channel, encode_wrench(utime, zeros[:3], zeros[:3])
            )
        lcm.Publish(
            scenario.iiwa_driver.status_channel,
            encode_status(
                IiwaStatus(
                    utime,
                    np.asarray(q, float),
                    zeros if v is None else v,
                    zeros,
                    zeros,
                    zeros if torque_external is None else torque_external,
                )
            ),
        )
        lcm.HandleSubscriptions(0)
        for each in (client, *also):  # clients answering before they hear each other
            each.poll()
        lcm.HandleSubscriptions(0)

    return client, send, commands


def test_watchdogs_name_the_problem():
    client, send, commands = _client_fed_by_hand()
    send(0, client.q0 + 0.2)
    assert (
        client.status == STOPPED
        and "not at the scenario's start posture: joint 1 is 0.200 rad away"
        in client.stopped_because
        and not commands
    )

    client, send, commands = _client_fed_by_hand()
    send(0, client.q0)
    time.sleep(0.002)
    send(0, client.q0)
    send(1000, client.q0)
    assert len(commands) == 2 and not client.done
    beyond = client.q0.copy()
    beyond[3] = -2.2  # iiwa joint 4's limit is ±2.094 rad
    send(2000, beyond)
    assert (
        client.status == UNSAFE
        and "joint iiwa_joint_4 at -2.200 rad, beyond its limit" in client.stopped_because
    )
    assert len(commands) == 2

    for field in ("q", "v", "torque_external"):  # the three the tick reads, nan or inf
        for broken in (np.r_[np.nan, np.zeros(6)], np.r_[np.zeros(6), -np.inf]):
            client, send, commands = _client_fed_by_hand()
            send(0, client.q0)
            time.sleep(0.002)
            values = {"q": client.q0, "v": None, "torque_external": None}
            values[field] = (client.q0 if field == "q" else 0.0) + broken
            send(0, **values)
            assert (
                client.status == UNSAFE
                and "non-finite value in the status" in client.stopped_because
                and not commands
            ), field

    # The wrist force estimated from the external torques: 300 N at the tool point trips the
    # scenario's 200 N contact-force limit.
    client, send, commands = _client_fed_by_hand(["iiwa_driver.force_source=external_torque"])
    send(0, client.q0)
    time.sleep(0.002)
    plant, world = client.plant, client.plant.world_frame()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, client.q0)
    tool = plant.GetFrameByName("tip", plant.GetModelInstanceByName("insertion_tool"))
    jacobian = plant.CalcJacobianTranslationalVelocity(
        context, JacobianWrtVariable.kV, tool, np.zeros(3), world, world
    )
    send(0, client.q0, torque_external=jacobian.T @ np.array([0.0, 0.0, 300.0]))
    assert (
        client.status == UNSAFE
        and "contact force 300.0 N above max_contact_force_N" in client.stopped_because
    )


def test_a_client_answering_every_other_status_still_checks_and_logs_at_100_hz():
    """A client that falls behind answers the newest status, which may be every second one:
    its 100 Hz checks (and its logs, and its look for another client's commands) run at the
    first answered tick of each log period, not only at ticks on the period's grid, which
    it might never answer (seen in CI: no look for 64 commands, its own taken for
    another's)."""
    client, send, commands = _client_fed_by_hand()
    send(0, client.q0)
    time.sleep(0.002)
    send(0, client.q0)
    for k in range(1, 42, 2):  # statuses 1, 3, 5, ..., 41 ms: never a multiple of 10 ms
        send(1000 * k, client.q0)
    assert not client.done and len(commands) == 22
    assert client.log_t == pytest.approx([0.0, 0.011, 0.021, 0.031, 0.041])


def test_a_wrist_sensor_that_is_silent_or_goes_quiet_stops_the_commands():
    """The contact force comes from the wrist sensor (the default): with no wrench on its
    channel by the end of the start guard (a sensor missing, a channel misspelt) nothing
    is commanded, and one that stops publishing mid-run stops the commands at the next
    check (100 Hz), as a driver that goes quiet does; neither is served as no force."""
    client, send, commands = _client_fed_by_hand()
    send(0, client.q0, wrench=False)
    time.sleep(0.002)
    send(1000, client.q0, wrench=False)
    assert client.status == STOPPED and not commands
    assert client.stopped_because.startswith(
        "no wrench on IIWA_WRIST_FT during the start guard (0.001 s): is the wrist F/T sensor "
        "publishing there (iiwa_driver.wrist_channel)?"
    )

    client, send, commands = _client_fed_by_hand()
    send(0, client.q0)
    time.sleep(0.002)
    for k in range(12):
        send(1000 * k, client.q0)
    assert len(commands) == 12 and not client.done
    time.sleep(0.06)  # the sensor's last wrench is older than stale_status_s (50 ms)
    for k in range(12, 22):
        send(1000 * k, client.q0, wrench=False)
    # The check at t = 0.02 s follows that tick's command, as every check does: 21 in all.
    assert client.status == STOPPED and len(commands) == 21
    assert client.stopped_because == (
        "no wrench on IIWA_WRIST_FT for 50 ms (the wrist F/T sensor went quiet: the contact "
        "force is not checked) at t = 0.020 s"
    )


def test_statuses_whose_stamp_stops_advancing_stop_the_commands():
    """A driver that keeps sending statuses but never takes a command (the client publishes
    on a channel it does not read) never advances its stamp: after stale_status_s the
    client stops and names the command channel, rather than resending its command until
    the driver gives up and then blaming a silence that never was."""
    client, send, commands = _client_fed_by_hand()
    send(0, client.q0)
    time.sleep(0.002)
    send(0, client.q0)  # the first command
    start = time.perf_counter()
    while not client.done and time.perf_counter() - start < 1.0:
        send(0, client.q0)  # the same status, again and again
        time.sleep(0.001)
    assert client.status == STOPPED
    assert time.perf_counter() - start < 0.2
    assert client.stopped_because == (
        "the driver's statuses kept coming but none newer than utime 0 for 50 ms from t = "
        "0.000 s: it takes no command on IIWA_COMMAND (iiwa_driver.command_channel), or it "
        "restarted?"
    )


def test_saturated_torques_stop_the_client_after_max_saturation_s():
    """An arm held 5 cm from its reference against a 10^6 N/m impedance: the torques sit at
    their limits, and the client stops once that has lasted longer than max_saturation_s
    (0.25 s), checked at 100 Hz as in a simulated run."""
    stiff = "controllers.const_2000.stiffness_N_per_m=[1000000.0,1000000.0,1000000.0]"
    client, send, commands = _client_fed_by_hand([stiff], controller="const_2000")
    send(0, client.q0)
    time.sleep(0.002)
    displaced = (
        client.q0 + np.r_[0.0, 0.08, 0.0, 0.0, 0.0, 0.0, 0.0]
    )  # the shoulder: the tip moves ~5 cm
    for k in range(400):
        send(1000 * k, client.q0 if k == 0 else displaced)
        if client.done:
            break
    assert client.status == UNSAFE
    assert (
        client.stopped_because
        == "joint torques saturated for more than max_saturation_s = 0.25 s at t = 0.260 s"
    )
    assert (
        len(commands) == 261
    )  # saturated from the check at 0.01 s; the check after tick 260 stops the next


@pytest.mark.parametrize(
    "args, message",
    [
        (["serve", "one_dof", "--lcm", "memq://"], "has no arm: hlcmp serve drives an iiwa"),
        (
            ["serve", "insertion", "--lcm", "memq://", "--controller", "nope"],
            "has no controller 'nope'",
        ),
        (["serve", "insertion", "--lcm", "memq://", "--freeze"], "--freeze needs --skill"),
        # --duration named as typed, not as an override 'duration_s=1000000000.0' never typed
        (
            ["serve", "insertion", "--lcm", "memq://", "--duration", "1e9"],
            "hlcmp: error: --duration 1e9: duration_s: must be at most 3600 s, got 1e+09: ",
        ),
        (
            ["serve", "insertion", "--lcm", "memq://", "--set", "duration_s=2"]
            + ["--duration", "1e9"],
            "hlcmp: error: --duration 1e9: duration_s: must be at most 3600 s, got 1e+09: ",
        ),
        (
            [
                "serve",
                "insertion",
                "--lcm",
                "memq://",
                "--set",
                "robot_imperfection.link_mass_error=-0.03",
            ],
            "robot_imperfection is set: hlcmp serve drives an iiwa as its model is",
        ),
        (
            [
                "sim-driver",
                "cutting",
                "--lcm",
                "udpm://239.255.76.1:7667?ttl=0",
                "--set",
                "robot_imperfection.link_mass_error=-0.03",
            ],
            "robot_imperfection is set: the simulated iiwa driver drives an arm as its model is",
        ),
        (["serve", "insertion", "--lcm", "memq://", "--any-scenario"], "--any-scenario needs"),
        (["serve", "insertion", "--lcm", "tcp://x:1"], "expected udpm://GROUP:PORT?ttl=0"),
        (
            ["serve", "insertion", "--lcm", "udpm://239.255.76.1:7667?ttl=abc"],
            "ttl must be a whole number from 0 to 255 (decimal, no leading zero), got 'abc'",
        ),
        (
            ["serve", "insertion", "--lcm", "udpm://239.255.76.1:7667?ttl=²"],
            "ttl must be a whole number from 0 to 255 (decimal, no leading zero), got '²'",
        ),
        (
            ["serve", "insertion", "--lcm", "udpm://239.255.76.1:7667?ttl=010"],
            "got '010'",
        ),
        (
            ["sim-driver", "insertion", "--lcm", "udpm://239.255.76.1:7667?ttl=0,rcv_buf=9"],
            "unknown option 'rcv_buf': udpm:// takes ttl and recv_buf_size",
        ),
        (["sim-driver", "insertion", "--lcm", "memq://"], "memq:// reaches only this process"),
        (
            ["sim-driver", "insertion", "--lcm", "memq://", "--drake-driver"],
            "memq:// reaches only this process",
        ),
        (
            ["sim-driver", "insertion", "--lcm", "memq://", "--status-period", "0.001"],
            "--status-period needs --drake-driver",
        ),
        (
            ["sim-driver", "insertion", "--lcm", "memq://", "--drake-driver", "--realtime"],
            "--drake-driver runs Drake's driver as it is",
        ),
        (["sim-driver", "insertion", "--lcm", "memq://", "--command-delay", "0.5"], "whole"),
        (
            ["sim-driver", "insertion", "--lcm", "udpm://239.255.76.1:7667?ttl=0"]
            + ["--command-delay", "2000", "--duration", "2"],
            "--command-delay 2000: 2 s of plant steps must be shorter than the run (2 s, "
            "--duration)",
        ),
        (
            ["sim-driver", "insertion", "--lcm", "udpm://239.255.76.1:7667?ttl=0"]
            + ["--drake-driver", "--status-period", "0.0015"],
            "must be a whole number of plant steps",
        ),
        (
            ["sim-driver", "insertion", "--lcm", "udpm://239.255.76.1:7667?ttl=0"]
            + ["--drake-driver", "--set", "iiwa_driver.status_channel=OTHER"],
            "Drake's iiwa driver publishes on IIWA_STATUS",
        ),
        (
            ["serve", "insertion", "--lcm", "memq://", "--set", "iiwa_driver.force_source=guess"],
            "iiwa_driver.force_source",
        ),
        (
            ["serve", "insertion", "--lcm", "memq://", "--set", "iiwa_driver.period_s=1"]
            + ["--duration", "0.2"],
            "iiwa_driver.period_s: a status every 1 s is longer than the whole run served "
            "(0.2 s, --duration or duration_s)",
        ),
    ],
)
def test_bad_serve_input_is_one_line_and_exit_2(args, message, tmp_path):
    out = ["--out", tmp_path / "o"] if args[0] == "serve" else []
    assert message in one_line_error(run_cli(*args, *out))


def test_a_realtime_priority_the_process_may_not_take_is_refused_before_the_client_is_made(
    tmp_path, monkeypatch
):
    def refused(*args):
        raise PermissionError(errno.EPERM, "Operation not permitted")

    made = []
    monkeypatch.setattr(os, "sched_setscheduler", refused)
    monkeypatch.setattr(serve_module, "TorqueClient", lambda *args: made.append(args))
    line = one_line_error(
        run_cli(
            "serve",
            "insertion",
            "--lcm",
            "udpm://239.255.76.3:7667?ttl=0",
            "--set",
            "iiwa_driver.realtime_priority=50",
            "--out",
            tmp_path / "o",
        )
    )
    assert "iiwa_driver.realtime_priority" in line and "SCHED_FIFO priority 50" in line
    assert "CAP_SYS_NICE" in line and not made and not (tmp_path / "o").exists()


def test_a_realtime_client_that_would_never_sleep_is_refused_where_linux_throttles_it(
    tmp_path, monkeypatch
):
    runtime, period = tmp_path / "runtime", tmp_path / "period"
    monkeypatch.setattr(serve_module, "RT_RUNTIME_FILE", runtime)
    monkeypatch.setattr(serve_module, "RT_PERIOD_FILE", period)
    assert serve_module.realtime_throttling() is None  # no such files: nothing to say
    period.write_text("1000000\n")
    runtime.write_text("-1\n")  # no budget: never stopped
    assert serve_module.realtime_throttling() is None
    runtime.write_text("950000\n")  # Linux's default
    assert serve_module.realtime_throttling() == (50.0, 1000.0)
    made = []
    monkeypatch.setattr(serve_module, "TorqueClient", lambda *args: made.append(args))
    args = ["serve", "insertion", "--lcm", "udpm://239.255.76.3:7667?ttl=0", "--out", tmp_path]
    sets = ["--set", "iiwa_driver.realtime_priority=50", "--set", "iiwa_driver.busy_wait=true"]
    line = one_line_error(run_cli(*args, *sets))
    assert "iiwa_driver.busy_wait" in line and "for 50 ms of every 1000 ms" in line
    assert "kernel.sched_rt_runtime_us" in line and not made


def test_the_client_serves_at_its_realtime_priority_and_then_schedules_as_before():
    def scheduling():
        return os.sched_getscheduler(0), os.sched_getparam(0).sched_priority

    before = scheduling()
    try:
        with realtime_scheduling(7):
            assert scheduling() == (os.SCHED_FIFO, 7)
    except InputError as refused:  # neither root nor CAP_SYS_NICE here
        pytest.skip(str(refused))
    assert scheduling() == before
    with pytest.raises(RuntimeError), realtime_scheduling(3):
        raise RuntimeError("a tick failed")
    assert scheduling() == before
    with realtime_scheduling(0):
        assert scheduling() == before
    # memq://'s driver runs in the client's own thread: no priority for it.
    config = dc.replace(load_scenario("insertion")[0].iiwa_driver, realtime_priority=50)
    assert served_priority(config, "memq://") == 0
    assert served_priority(config, "udpm://239.255.76.3:7667?ttl=0") == 50


@pytest.mark.slow
def test_real_time_pacing(tmp_path):
    """The simulated driver in real time: a status every millisecond whether or not the
    client keeps up. Every status the client did not answer is counted as missed."""
    driver_out, record = serve_two_processes(
        tmp_path, ["--realtime", "--duration", 0.8], 0.5, client_codes=(0, 5)
    )
    assert "reached --duration 0.8 s" in driver_out
    assert record["ticks"] + record["missed_ticks"] == 501  # every status from t = 0 to 0.5 s
    assert record["ticks"] > 250
    # A run that missed more than the driver config allows says so (exit 5), never "ok".
    fraction = record["missed_ticks"] / 501
    too_many = fraction > 0.01 or record["longest_missed_run"] >= 10
    assert record["status"] == ("degraded" if too_many else "ok"), record
    assert record["status_period_s"] == pytest.approx(0.001)


def test_serve_in_one_process_from_the_command_line(tmp_path, capsys):
    """hlcmp serve --lcm memq:// runs the simulated driver in the same process; a frozen
    skill keeps its profiles (here the untrained ones: θ stays 0); its last line lists
    every file it wrote."""
    from hlcmp_drake.cli import main

    assert (
        main(
            [
                "fit",
                str(INSERTION_DEMO),
                "--out",
                str(tmp_path / "skill.npz"),
                "--basis",
                "30",
            ]
        )
        == 0
    )
    out = tmp_path / "served"
    assert (
        main(
            [
                "serve",
                "insertion",
                "--lcm",
                "memq://",
                "--skill",
                str(tmp_path / "skill.npz"),
                "--freeze",
                "--duration",
                "0.3",
                "--out",
                str(out),
                "--quiet",
            ]
        )
        == 0
    )
    printed = capsys.readouterr().out.strip().splitlines()
    last = printed[-1]
    assert last == f"serve.json, metrics.json, timeseries.npz, recording.html in {out}"
    assert_output_names(out)
    assert all((out / name).is_file() for name in last.split(" in ")[0].split(", "))
    record = json.loads((out / "serve.json").read_text())
    assert record["ticks"] == 301 and record["missed_ticks"] == 0 and record["status"] == "ok"
    # What was served: the skill file, frozen, and the overrides (--duration is one).
    assert record["skill"] == str(tmp_path / "skill.npz") and record["adaptation"] == "frozen"
    assert record["overrides"] == ["duration_s=0.3"]
    arrays = np.load(out / "timeseries.npz")
    assert arrays["t"][-1] == pytest.approx(0.3)
    assert np.all(arrays[f"{record['controller']}/Ks"] == 0.0)  # frozen: no adaptation
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["status"] == "ok" and record["controller"] in metrics["controllers"]
    # The task as learn and reproduce print it: 0.3 s does not reach the plank.
    task = metrics["controllers"][record["controller"]]["task"]
    assert not task["done"]
    assert f"task ({record['controller']}): NOT done -- {task['evidence']}" in printed


@pytest.mark.parametrize(
    "scenario_name, controller",
    [
        ("insertion", "const_500"),
        ("cutting", "hlcmp"),
        pytest.param(  # the peg simulated, then served (about 1.7 s)
            "peg_in_hole", "const_6d_stiff", marks=pytest.mark.slow
        ),
    ],
)
def test_served_controller_equals_its_simulated_run(scenario_name, controller, tmp_path):
    """A constant impedance, the cutting's Hl-CMP and a constant 6-D impedance: served over
    memq://, the same series as simulated (0.5 s)."""
    from hlcmp_drake.run.simulate import simulate
    from hlcmp_drake.worlds.build import diagram_factory

    scenario, _ = load_scenario(scenario_name, ["duration_s=0.5"])
    simulated = simulate(diagram_factory(scenario)(controller), scenario, controller)
    served = serve_scenario(
        scenario_name, "memq://", tmp_path, controller=controller, overrides=["duration_s=0.5"]
    ).run
    assert served.status == "ok" and served.series.keys() == simulated.series.keys()
    np.testing.assert_allclose(served.t, simulated.t, atol=1e-12)
    for name, values in simulated.series.items():
        assert np.abs(served.series[name] - values).max() <= 1e-9 * max(
            1.0, np.abs(values).max()
        ), name


def test_a_skill_from_another_world_is_not_served(tmp_path, capsys, monkeypatch):
    """An insertion skill served in the cutting world: one line, exit 2, before the LCM is
    opened; --any-scenario serves it with a warning line. In a world without an arm the
    refusal is for that, where --any-scenario would not help."""
    from hlcmp_drake.cli import main
    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.config.world import world_of_scenario
    from hlcmp_drake.io.skill import Skill, save_skill
    from hlcmp_drake.worlds.arm import fit_demonstration

    insertion, _ = load_scenario("insertion")
    skill = Skill.untrained(fit_demonstration(insertion))
    path = save_skill(tmp_path / "skill.npz", dc.replace(skill, world=world_of_scenario(insertion)))

    class Opened(Exception):
        pass

    def open_lcm(url):
        raise Opened(url)

    monkeypatch.setattr("hlcmp_drake.run.serve.open_lcm", open_lcm)
    args = ["serve", "cutting", "--lcm", "memq://", "--skill", str(path), "--freeze"]
    assert main([*args, "--out", str(tmp_path / "o")]) == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "the skill was learned in 'insertion'" in error[0], error
    with pytest.raises(Opened):
        main([*args, "--any-scenario", "--out", str(tmp_path / "o")])
    assert "used here all the same" in capsys.readouterr().err
    # A world no skill is served in says so first, not "pass --any-scenario".
    for any_scenario in ([], ["--any-scenario"]):
        one_dof = ["serve", "one_dof", "--lcm", "memq://", "--skill", str(path), *any_scenario]
        assert main([*one_dof, "--out", str(tmp_path / "o")]) == 2
        assert capsys.readouterr().err.strip().splitlines() == [
            "hlcmp: error: scenario 'one_dof' has no arm: hlcmp serve drives an iiwa, use an "
            "arm scenario such as insertion or cutting"
        ]


def test_a_skill_that_does_not_fit_the_scenario_is_named_by_its_file(tmp_path):
    """serve --skill with a skill of other axes than the scenario's: the one line names the
    skill's file, as learn and reproduce do, before the LCM is opened."""
    demo, skill = tmp_path / "z.csv", tmp_path / "z.npz"
    demo.write_text("t,z\n" + "".join(f"{0.1 * k:.1f},{0.2 - 0.01 * k:.2f}\n" for k in range(20)))
    assert run_cli("fit", demo, "--out", skill).returncode == 0
    serve = ["serve", "insertion", "--lcm", "memq://", "--skill", skill]
    line = one_line_error(run_cli(*serve, "--out", tmp_path / "o"))
    assert line == (
        f"hlcmp: error: {skill}: the skill's axes (z) do not match the scenario 'insertion', "
        "which controls x,y,z"
    )
    assert not (tmp_path / "o").exists()


def test_a_skills_replay_duration_is_checked_against_the_skill(tmp_path, monkeypatch):
    """serve --skill --set reference.duration_s: the skill (the insertion's first second)
    is what is replayed, so 0.2 s is served and 0.03 s refused naming the skill, not the
    scenario's 8.5 s demonstration."""
    from hlcmp_drake.cli import main
    from hlcmp_drake.core.dmp import Dmp
    from hlcmp_drake.io.demos import read_demonstration
    from hlcmp_drake.io.skill import Skill, save_skill

    class Opened(Exception):
        pass

    def open_lcm(url):
        raise Opened(url)

    monkeypatch.setattr("hlcmp_drake.run.serve.open_lcm", open_lcm)
    t, positions, axes = read_demonstration(INSERTION_DEMO)
    skill = save_skill(
        tmp_path / "first.npz", Skill.untrained(Dmp.fit(t[:100], positions[:100], axes))
    )
    serve = ["serve", "insertion", "--lcm", "memq://", "--skill", skill, "--freeze"]
    too_fast = [*serve, "--set", "reference.duration_s=0.03"]
    for out in ([], ["--out", tmp_path / "o"]):  # the default --out reads the scenario too
        line = one_line_error(run_cli(*too_fast, *out))
        assert "replays the 0.99 s skill first.npz in 0.03 s, 33 times as fast" in line
    with pytest.raises(Opened):
        main([*map(str, serve), "--set", "reference.duration_s=0.2", "--out", str(tmp_path)])


def test_a_status_period_other_than_the_configured_one_stops_before_any_command():
    """A driver publishing every 5 ms to a client configured for 1 ms: said from the stamps
    during the start guard, with the fix, before a command goes out."""
    client, send, commands = _client_fed_by_hand(["iiwa_driver.start_guard_s=5.0"])
    for utime in range(0, 50000, 5000):  # nine steps: not yet enough to call it
        send(utime, client.q0)
    assert not client.done
    send(50000, client.q0)
    assert client.status == STOPPED and not commands
    assert client.stopped_because.startswith("the driver's statuses come every 5 ms")
    assert "--set iiwa_driver.period_s=0.005" in client.stopped_because
    assert client.record("memq://")["status_period_s"] == pytest.approx(0.005)


def test_the_reported_period_is_the_drivers_step_not_a_truncated_or_a_lost_one():
    """Stamps truncated to the µs (steps of 4999 and 10001 among 5000 and 10000, as a
    driver whose clock is a float makes them) and every third status lost (half the steps
    10 ms): the period recorded is the median step with none lost in it, 5 ms, neither
    the shortest (4.999 ms) nor a step over a lost status."""
    client, send, commands = _client_fed_by_hand(
        ["iiwa_driver.period_s=0.005", "iiwa_driver.start_guard_s=5.0"]
    )
    kept = [k for k in range(40) if k % 3 != 1]  # every third status lost
    for k in kept:
        send(5000 * k - (k in (3, 9, 15)), client.q0)
    assert not client.done, client.stopped_because
    assert client._shortest_step_s == pytest.approx(0.004999, abs=1e-9)
    assert client.record("memq://")["status_period_s"] == 0.005


def _served_with_gaps(skipped, overrides=()):
    """A hand-fed client over 0.1 s of 1 ms statuses, the statuses whose index is in
    `skipped` never sent; returns the client after its assessment and the commands."""
    client, send, commands = _client_fed_by_hand(["duration_s=0.1", *overrides])
    send(0, client.q0)
    time.sleep(0.002)  # past the start guard: the next status starts the run
    for k in range(0, 102):
        if k not in skipped:
            send(1000 * (k + 1), client.q0)
    client.assess()
    return client, commands


def test_a_second_client_on_the_command_channel_stops():
    """A client that sees a command it did not send on the command channel stops, naming
    it: one that joins a running client never commands, two that answer the same status
    both stop. Alone, its own commands coming back (LCM hands a process what it
    published, a repeated status's command too) never stop it."""
    client, send, commands = _client_fed_by_hand()
    late = TorqueClient(client.scenario, "hlcmp", client._lcm)
    send(0, client.q0, also=[late])
    time.sleep(0.002)
    send(0, client.q0)  # the first client's first command
    send(1000, client.q0, also=[late])
    assert late.status == STOPPED and late.stopped_because.startswith(
        "another client commands the arm on IIWA_COMMAND (iiwa_driver.command_channel) at "
    )
    assert not client.done and len(commands) == 2  # the late one sent none

    client, send, commands = _client_fed_by_hand()
    other = TorqueClient(client.scenario, "hlcmp", client._lcm)
    send(0, client.q0, also=[other])
    time.sleep(0.002)
    send(0, client.q0, also=[other])  # both answer it
    assert len(commands) == 2
    assert client.status == other.status == STOPPED
    assert "another client commands the arm" in client.stopped_because
    send(1000, client.q0, also=[other])
    assert len(commands) == 2  # neither commands again

    alone, send, commands = _client_fed_by_hand(["duration_s=0.1"])
    send(0, alone.q0)
    time.sleep(0.002)
    for k in range(0, 102):
        send(1000 * k, alone.q0)
        if k % 10 == 0:
            send(1000 * k, alone.q0)
    alone.assess()
    # 101 ticks (0 to 0.1 s), the repeats of k = 0, 10, ..., 90 re-sent (k = 100 ended it)
    assert alone.status == "ok" and alone.ticks == 101 and len(commands) == 101 + 10


def test_missed_ticks_above_the_allowed_share_make_the_run_degraded():
    client, _ = _served_with_gaps(set())
    assert client.status == "ok" and client.missed_ticks == 0
    client, _ = _served_with_gaps({10, 30, 50, 70})  # 4 of 101: 4 %
    assert client.status == "degraded" and client.missed_ticks == 4
    assert client.stopped_because.startswith("missed 4 of 101 ticks (4.0 %), above")
    client, _ = _served_with_gaps(set(range(20, 32)), ["iiwa_driver.max_missed_fraction=0.5"])
    assert client.status == "degraded" and client.longest_missed_run == 12
    assert "missed 12 ticks in a row" in client.stopped_because


def test_a_gap_is_not_integrated_as_one_long_step_and_a_status_is_answered_once():
    client, send, commands = _client_fed_by_hand()
    send(0, client.q0)
    time.sleep(0.002)
    send(0, client.q0)
    displaced = client.q0 + 0.01  # a tracking error, so θ moves
    send(1000, displaced)
    theta, rate = client.theta.copy(), client._rate
    send(6000, displaced)  # four statuses missed
    np.testing.assert_allclose(client.theta, theta + 0.001 * rate)  # one period's step
    answered = len(commands)
    send(6000, displaced)  # the same status again: its command re-sent, no new tick
    assert len(commands) == answered + 1 and commands[-1] == commands[-2]
    ticks = client.ticks
    send(3000, displaced)  # older than one answered: ignored
    assert len(commands) == answered + 1 and client.ticks == ticks


def test_a_driver_that_goes_quiet_before_any_logged_tick_ends_in_one_line(tmp_path):
    """Statuses come, but none is answered before the driver goes quiet: no traceback,
    serve.json and metrics.json say it stopped."""
    client, send, commands = _client_fed_by_hand(["iiwa_driver.start_guard_s=5.0"])
    send(0, client.q0)
    send(1000, client.q0)
    serve(client, client._lcm, "memq://")  # the stale watchdog ends it
    assert client.status == STOPPED and "stale" in client.stopped_because and not commands
    result = write_served(client, tmp_path, "memq://")
    assert result.metrics["status"] == "stopped" and result.metrics["controllers"] == {}
    assert json.loads((tmp_path / "serve.json").read_text())["ticks"] == 0


def test_statuses_queued_while_the_client_was_busy_do_not_fool_the_period():
    """A driver at 5 ms whose statuses reach the client three at a time (the client was
    busy, e.g. collecting garbage before serving): each status's stamp counts, so the
    period is 5 ms and the run goes on, though only every third status is decoded."""
    client, send, commands = _client_fed_by_hand(
        ["iiwa_driver.period_s=0.005", "iiwa_driver.start_guard_s=5.0"]
    )
    channel = client.config.status_channel
    for burst in range(4):
        for k in range(3):
            stamp = 5000 * (3 * burst + k)
            client._lcm.Publish(
                channel,
                encode_status(IiwaStatus(stamp, client.q0, *(np.zeros(7) for _ in range(4)))),
            )
        client._lcm.HandleSubscriptions(0)
        client.poll()
    assert not client.done, client.stopped_because
    assert client.record("memq://")["status_period_s"] == pytest.approx(0.005)


@pytest.mark.parametrize(
    "driver_duration, ticks, reason",
    [
        (None, [0], "no status on IIWA_STATUS at udpm://"),  # no driver: it stopped before
        pytest.param(  # after the first tick; the watchdog waits 0.5 s (about 1.6 s)
            0.0005, [1], "no status for 500 ms (stale) at t = 0.000 s", marks=pytest.mark.slow
        ),
        pytest.param(  # mid-run; the watchdog waits 0.5 s (about 1.7 s)
            0.3, [300, 301], "no status for 500 ms (stale) at t = 0.3", marks=pytest.mark.slow
        ),
    ],
)
def test_a_driver_that_stops_ends_the_served_run_in_one_line(
    driver_duration, ticks, reason, tmp_path
):
    """hlcmp serve against a driver that stops before its first status, right after the
    first tick, or mid-run: exit 3, one line on stderr saying why, no traceback, and
    serve.json counting the ticks answered. (The stale watchdog is given 0.5 s here, so a
    busy machine cannot end the run before the driver does. Mid-run, the driver's last
    status, sent as it exits and never sent again, may be lost: 300 or 301 ticks.)"""
    url = f"udpm://239.255.76.{random.randint(100, 250)}:{random.randint(20000, 60000)}?ttl=0"
    driver = None
    if driver_duration is not None:
        driver = hlcmp("sim-driver", "insertion", "--lcm", url, "--duration", driver_duration)
    try:
        result = run_cli(
            "serve",
            "insertion",
            "--lcm",
            url,
            "--duration",
            "2",
            "--out",
            tmp_path,
            "--set",
            "iiwa_driver.stale_status_s=0.5",
            "--set",
            f"iiwa_driver.first_status_timeout_s={0.5 if driver is None else 120}",
        )
    finally:
        if driver is not None:
            driver_out, driver_err = driver.communicate(timeout=60)
    line = one_line_error(result, code=3)
    assert "Traceback" not in result.stdout
    record = json.loads((tmp_path / "serve.json").read_text())
    assert record["status"] == "stopped" and record["ticks"] in ticks
    served = f"{record['served_s']:.3f} s"
    assert reason in line and (driver is None or line.endswith(served)), line
    if driver is not None:
        assert driver.returncode == 0 and "reached --duration" in driver_out, driver_err


def test_jitter_in_the_statuses_arrival_changes_no_command():
    """The same statuses (1 ms stamps, a drifting arm) delivered back to back and with
    0-3 ms of random lateness each: the same commands, byte for byte, and the same θ.
    The client steps θ and samples the reference by the stamps, never by the clock."""
    rng = random.Random(7)
    runs = []
    for jitter in (False, True):
        client, send, commands = _client_fed_by_hand()
        send(0, client.q0)
        time.sleep(0.002)
        for k in range(40):
            if jitter:
                time.sleep(rng.uniform(0.0, 0.003))
            send(1000 * k, client.q0 + 0.0005 * k, v=np.full(7, 0.5))
        runs.append((commands, client.theta.copy()))
    (steady, theta), (late, theta_late) = runs
    assert len(steady) == 40 and late == steady
    np.testing.assert_array_equal(theta_late, theta)
    assert np.abs(theta).max() > 0  # θ moved


def test_statuses_that_queue_up_are_answered_once_the_newest_only():
    """Two statuses reach the client at once (one was late): only the newer is answered,
    the older counts as missed, and θ takes one period's step; a copy of the older one
    arriving after that (out of order) is ignored."""
    client, send, commands = _client_fed_by_hand()
    send(0, client.q0)
    time.sleep(0.002)
    displaced = client.q0 + 0.01
    send(0, displaced)
    send(1000, displaced)
    theta, rate, answered = client.theta.copy(), client._rate, len(commands)
    channel = client.config.status_channel
    for stamp in (2000, 3000):  # queued together
        client._lcm.Publish(
            channel, encode_status(IiwaStatus(stamp, displaced, *(np.zeros(7) for _ in range(4))))
        )
    client._lcm.HandleSubscriptions(0)
    client.poll()
    client._lcm.HandleSubscriptions(0)
    assert len(commands) == answered + 1 and client.missed_ticks == 1
    np.testing.assert_allclose(client.theta, theta + 0.001 * rate)
    send(2000, displaced)  # the late one again, after the newer was answered
    assert len(commands) == answered + 1 and client.ticks == 3


def test_a_warm_up_before_each_status_changes_no_command():
    """The same drifting statuses answered with and without a throw-away tick before each
    (`warm_up_lead_s`, called between statuses as `serve` calls it): the same commands,
    byte for byte, and the same θ."""
    runs = []
    for lead in (0.0, 0.0005):
        client, send, commands = _client_fed_by_hand([f"iiwa_driver.warm_up_lead_s={lead}"])
        evaluations: list = []

        def counted(*args, evaluate=client.tick.evaluate, calls=evaluations, **keywords):
            calls.append(1)
            return evaluate(*args, **keywords)

        client.tick.evaluate = counted
        send(0, client.q0)
        time.sleep(0.002)
        for k in range(30):
            client.warm_up()
            send(1000 * k, client.q0 + 0.0005 * k, v=np.full(7, 0.5))
        runs.append((commands, client.theta.copy(), len(evaluations), client.warm_up_overlaps))
    (plain, theta, ticks, _), (warmed, theta_warmed, evaluated, overlaps) = runs
    assert len(plain) == 30 and warmed == plain and overlaps == 0
    np.testing.assert_array_equal(theta_warmed, theta)
    assert ticks == 30 and evaluated == 30 + 29  # a warm-up after each answered status


def test_a_status_that_comes_during_the_warm_up_counts_its_wait():
    """A status already waiting when the warm-up starts is taken after it, as received
    when the client stopped listening: its tick time holds the warm-up's."""
    client, send, commands = _client_fed_by_hand(["iiwa_driver.warm_up_lead_s=0.0009"])
    send(0, client.q0)
    time.sleep(0.002)
    send(0, client.q0)
    channel, zeros = client.config.status_channel, np.zeros(7)
    client._lcm.Publish(channel, encode_status(IiwaStatus(1000, client.q0, *[zeros] * 4)))
    started = time.perf_counter()
    client.warm_up()
    warm_up_s = time.perf_counter() - started
    assert client.pending and client.warm_up_overlaps == 1
    client.poll()
    client._lcm.HandleSubscriptions(0)  # the command
    assert len(commands) == 2 and client.tick_seconds[-1] >= warm_up_s * 0.9
    assert client.record("memq://")["warm_up_overlaps"] == 1
    client.warm_up()  # no warm-up twice after one status... until the next is answered
    assert client.warm_up_overlaps == 1


@pytest.mark.slow
def test_served_6d_hlcmp_equals_its_simulated_run_through_the_contact(tmp_path):
    """hlcmp serve peg_in_hole --lcm memq:// serves the 6-D Hl-CMP (the first learner) and
    ends ok; for 4.2 s, through the peg's first contact with the chamfer (at 3.4 s), its
    series (R_d, the learned K_r, D_r, v_r, the wrist force and torque among them) and
    metrics are those of the simulated run, within the insertion test's tolerances."""
    from types import SimpleNamespace

    from hlcmp_drake.cli import main
    from hlcmp_drake.experiments import experiment_of, peg_in_hole
    from hlcmp_drake.run.simulate import simulate
    from hlcmp_drake.worlds.build import diagram_factory

    out = tmp_path / "served"
    args = ["serve", "peg_in_hole", "--lcm", "memq://", "--duration", "4.2", "--out", out]
    assert main([*map(str, args), "--quiet"]) == 0
    record = json.loads((out / "serve.json").read_text())
    assert record["controller"] == "hlcmp_6d" and record["status"] == "ok"
    assert record["ticks"] == 4201 and record["missed_ticks"] == 0

    scenario, _ = load_scenario("peg_in_hole", ["duration_s=4.2"])
    simulated = simulate(diagram_factory(scenario)("hlcmp_6d"), scenario, "hlcmp_6d")
    served = np.load(out / "timeseries.npz")
    np.testing.assert_allclose(served["t"], simulated.t, atol=1e-12)
    assert {key for key in served.files if key != "t"} == {
        f"hlcmp_6d/{name}" for name in simulated.series
    }
    for name, values in simulated.series.items():
        scale = max(1.0, np.abs(values).max())
        assert np.abs(served[f"hlcmp_6d/{name}"] - values).max() <= 1e-9 * scale, name
    # It touched the hole: the wrist force and torque compared are not zeros.
    assert np.abs(simulated.series["f_ext"]).max() > 5.0
    assert np.abs(simulated.series["tau_ext"]).max() > 0.05
    config = scenario.controllers["hlcmp_6d"]
    expected = experiment_of(scenario).metrics_of(simulated, config, scenario)
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["status"] == "ok"
    assert_metrics_match(metrics["controllers"]["hlcmp_6d"], json.loads(json.dumps(expected)))
    # metrics.json is recomputed from timeseries.npz alone, and the tool's orientation from
    # the logged plant state is the one the tick logged.
    logged = SimpleNamespace(
        t=served["t"], series={name: served[f"hlcmp_6d/{name}"] for name in simulated.series}
    )
    assert experiment_of(scenario).metrics_of(logged, config, scenario) == json.loads(
        json.dumps(metrics["controllers"]["hlcmp_6d"])
    )
    measured = peg_in_hole.tool_orientations(logged, scenario)
    same_sign = np.sign(np.sum(measured * logged.series["q_tool"], axis=1))[:, None]
    np.testing.assert_allclose(same_sign * measured, logged.series["q_tool"], atol=1e-9)


def test_a_6d_skill_is_served_with_its_rotational_weights(tmp_path):
    """A pose skill with the six weight arrays (as `hlcmp fit` makes of a pose
    demonstration) serves peg_in_hole's 6-D learner; given to the translational learner it
    is refused in one line."""
    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.io.errors import InputError
    from hlcmp_drake.io.skill import Skill
    from hlcmp_drake.worlds.arm import prepare

    scenario, _ = load_scenario("peg_in_hole")
    setup = prepare(scenario)
    skill = Skill.untrained(setup.dmp, orientation=setup.orientation_dmp)
    assert len(skill.theta) == 6
    served = serve_scenario(
        "peg_in_hole", "memq://", tmp_path / "six", skill=skill, overrides=["duration_s=0.2"]
    )
    assert served.run.status == "ok" and "Kr" in served.run.series
    with pytest.raises(InputError) as refused:
        serve_scenario(
            "peg_in_hole", "memq://", tmp_path / "three", skill=skill, controller="hlcmp"
        )
    assert "\n" not in str(refused.value)


@pytest.mark.parametrize(
    "period, given, lead",
    [
        (0.001, None, 0.0),
        (0.005, None, 0.002),
        (0.005, 0.0, 0.0),
        (0.001, 0.0004, 0.0004),
        (0.004, None, 0.0016),
    ],  # fmt: skip
)
def test_the_warm_up_is_on_by_default_only_for_a_period_that_leaves_the_client_idle(
    period, given, lead
):
    from hlcmp_drake.config.scenario import AUTO_WARM_UP_POLL_S, IiwaDriverConfig

    config = IiwaDriverConfig(period_s=period, warm_up_lead_s=given)
    assert config.warm_up_lead() == pytest.approx(lead, abs=1e-15)
    # After a warm-up the client polls for the status; without one it sleeps as before.
    assert IiwaDriverConfig(period_s=period, warm_up_lead_s=given).warm_up_poll() == (
        AUTO_WARM_UP_POLL_S if lead else 0.0
    )
    assert IiwaDriverConfig(period_s=period, warm_up_poll_s=0.0).warm_up_poll() == 0.0


def test_after_the_warm_up_the_client_polls_until_the_status_is_late():
    """With `warm_up_poll_s`, the warm-up returns only when the status has come or that long
    after it was expected: the client polled (LCM's 0 ms wait) in between, where it would
    otherwise sleep in the serve loop's wait for a status."""
    from types import SimpleNamespace

    # A 5 ms period, as Drake's driver's: the poll's window (from the warm-up's end, 2 ms
    # before the status, to 4 ms after) holds many polls even on a loaded machine.
    client, send, _ = _client_fed_by_hand(
        [
            "iiwa_driver.period_s=0.005",
            "iiwa_driver.warm_up_lead_s=0.002",
            "iiwa_driver.warm_up_poll_s=0.004",
        ]
    )
    send(0, client.q0)
    time.sleep(0.002)
    send(2000, client.q0)  # stamped as it is sent: the next is expected 5 ms from now
    waits = []
    handle = client._lcm.HandleSubscriptions
    client._lcm = SimpleNamespace(HandleSubscriptions=lambda ms: waits.append(ms) or handle(ms))
    expected = client._answered_stamp / 1e6 + 0.005 + client._stamp_offset_s
    client.warm_up()  # no status comes
    assert time.perf_counter() >= expected + 0.004 and not client.pending
    assert waits.count(0) > 1  # polled, not one look after the warm-up
