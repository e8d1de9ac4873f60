"""hlcmp_drake.run.sim_driver (hlcmp sim-driver): the simulated iiwa driver's start guard,
its --command-delay and --duration, what its summary counts, and Ctrl-C or SIGTERM."""

import os
import random
import signal
import threading
import time

import numpy as np
import pytest
from pydrake.lcm import DrakeLcm

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.io.iiwa_lcm import (
    decode_status,
    encode_torque_command,
)
from hlcmp_drake.run.sim_driver import DriverAbort, SimulatedIiwaDriver

UDPM = "udpm://239.255.76.67:7667?ttl=0"


def answering_client(lcm, scenario, until_utime, on_answer=None):
    """A client on `lcm` that answers each status stamped before `until_utime` with a zero
    torque command, and then goes quiet; `on_answer(utime)` after each answer."""

    def answer(data):
        utime = decode_status(data, 7).utime
        if utime < until_utime:
            command = encode_torque_command(utime, np.zeros(7), np.zeros(7))
            lcm.Publish(scenario.iiwa_driver.command_channel, command)
            if on_answer is not None:
                on_answer(utime)

    lcm.Subscribe(scenario.iiwa_driver.status_channel, answer)


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
    url = UDPM
    with pytest.raises(Opened):  # past every check of its input: 100 s of delay
        run_sim_driver("insertion", url, command_delay_steps=100_000)
    with pytest.raises(InputError, match=r"^--command-delay 2000: 2 s of plant steps must be "):
        run_sim_driver("insertion", url, duration=2.0, command_delay_steps=2000)


def test_a_command_delay_is_checked_against_the_steps_duration_runs(monkeypatch):
    """--duration ends at the whole period nearest it: --duration 0.0104 runs 10 periods
    of 1 ms, so a delay of 10 plant steps (0.01 s, shorter than 0.0104 s) was taken, and no
    command acted."""
    from hlcmp_drake.io.errors import InputError
    from hlcmp_drake.run.sim_driver import run_sim_driver

    class Opened(Exception):
        pass

    def open_lcm(url):
        raise Opened(url)

    monkeypatch.setattr("hlcmp_drake.run.sim_driver.open_lcm", open_lcm)
    with pytest.raises(Opened):
        run_sim_driver("insertion", UDPM, duration=0.0104, command_delay_steps=9)
    with pytest.raises(
        InputError,
        match=r"^--command-delay 10: 0.01 s of plant steps must be shorter than the run "
        r"\(0.01 s, --duration 0.0104 s to whole periods\)$",
    ):
        run_sim_driver("insertion", UDPM, duration=0.0104, command_delay_steps=10)
    with pytest.raises(Opened):  # no step, but no delay either: a driver that stops at once
        run_sim_driver("insertion", UDPM, duration=0.0005)


@pytest.mark.parametrize("delay, commanded", [(0, 50), (20, 30), (50, 0), (1000, 0)])
def test_only_the_steps_a_command_acted_in_count_as_commanded(monkeypatch, delay, commanded):
    """A client answers the statuses of the first 50 ms: with --command-delay N the first
    N plant steps (1 ms periods) run before its first command acts. They counted as
    commanded, so a delay longer than the run reported every step commanded."""
    from hlcmp_drake.run.sim_driver import drive

    monkeypatch.setattr("hlcmp_drake.run.sim_driver.START_COMMAND_GUARD_S", 0.0)
    scenario, _ = load_scenario("insertion", ["duration_s=1.0"])
    lcm = DrakeLcm("memq://")
    driver = SimulatedIiwaDriver(scenario, lcm, command_delay_steps=delay)
    answering_client(lcm, scenario, until_utime=50_000)
    summary = drive(driver, lcm, idle_timeout_s=0.1)
    assert summary.steps == 50 and summary.held_steps == 0
    assert summary.commanded_steps == commanded
    assert summary.command_delay_s == pytest.approx(delay * 0.001)


def test_a_realtime_run_counts_every_step_it_simulated(monkeypatch):
    """In real time the step that finds the client gone (a hold) was simulated but not
    counted, one short of the simulated time, and the summary then read "-1 waiting"."""
    from hlcmp_drake.run.sim_driver import drive

    monkeypatch.setattr("hlcmp_drake.run.sim_driver.START_COMMAND_GUARD_S", 0.0)
    scenario, _ = load_scenario("insertion", ["duration_s=1.0"])
    lcm = DrakeLcm("memq://")
    driver = SimulatedIiwaDriver(scenario, lcm)
    answering_client(lcm, scenario, until_utime=20_000)
    summary = drive(driver, lcm, realtime=True, idle_timeout_s=0.05)
    assert summary.stopped_because == "no command for 0.05 s (the client stopped)"
    assert summary.held_steps > 0  # its commands expired before the idle timeout
    assert summary.steps == summary.commanded_steps + summary.held_steps
    assert summary.steps == round(summary.sim_time_s / driver.period)


def test_the_summary_says_when_no_command_acted(monkeypatch):
    """Without --duration the run's length is the client's, unknown up front: a delay
    longer than it is taken, and the summary says that no command acted (it said every
    step was commanded, and exited 0 like its client)."""
    from conftest import run_cli

    monkeypatch.setattr("hlcmp_drake.run.sim_driver.START_COMMAND_GUARD_S", 0.0)
    scenario, _ = load_scenario("insertion")

    def open_lcm(url):
        lcm = DrakeLcm("memq://")
        answering_client(lcm, scenario, until_utime=50_000)
        return lcm

    monkeypatch.setattr("hlcmp_drake.run.sim_driver.open_lcm", open_lcm)
    args = ["sim-driver", "insertion", "--lcm", UDPM, "--idle-timeout", "0.1", "--quiet"]
    result = run_cli(*args, "--command-delay", "100")
    assert result.returncode == 0, result.stderr
    line = result.stdout.strip()
    assert line.startswith(
        "sim-driver: 50 steps (0 commanded, 0 held, 50 waiting out --command-delay 100), "
        "0.050 s simulated in "
    )
    assert line.endswith(
        "; the client stopped answering at t = 0.050 s (no command for 0.1 s); no command "
        "acted: --command-delay 100 (0.1 s of plant steps) is longer than the run"
    )
    acted = run_cli(*args, "--command-delay", "20").stdout.strip()
    assert acted.startswith("sim-driver: 50 steps (30 commanded, 0 held, 20 waiting out ")
    assert "no command acted" not in acted
    assert run_cli(*args).stdout.startswith("sim-driver: 50 steps (50 commanded, 0 held), ")


# Python's own handlers, as in a terminal: a pytest started in the background by a shell
# without job control inherits SIGINT ignored, and Python then installs none.
OWN_HANDLERS = {signal.SIGINT: signal.default_int_handler, signal.SIGTERM: signal.SIG_DFL}
STOPPING = pytest.mark.parametrize(
    "number, name", [(signal.SIGINT, "Ctrl-C"), (signal.SIGTERM, "SIGTERM")]
)


@pytest.fixture
def own_handlers():
    """`OWN_HANDLERS` in place, put back afterwards; the test checks that the driver put
    back these ones."""
    before = {number: signal.signal(number, handler) for number, handler in OWN_HANDLERS.items()}
    try:
        yield
    finally:
        for number, handler in before.items():
            signal.signal(number, handler)


def _handlers():
    return {number: signal.getsignal(number) for number in OWN_HANDLERS}


def _client_signalling(lcm, scenario, at_utime, number):
    """A client that answers every status and raises signal `number` (Ctrl-C's SIGINT, or
    SIGTERM) after answering `at_utime`'s."""

    def signal_(utime):
        if utime == at_utime:
            signal.raise_signal(number)

    answering_client(lcm, scenario, until_utime=10**12, on_answer=signal_)


@STOPPING
def test_ctrl_c_or_sigterm_stops_the_driver_between_two_steps_with_its_summary(
    monkeypatch, own_handlers, number, name
):
    """Ctrl-C ended the command at once ("hlcmp: interrupted; nothing was written") and
    dropped the summary, and SIGTERM (`timeout`, `kill`) killed it silently; either now
    stops the driver between two steps, and the summary says what it simulated up to then."""
    from hlcmp_drake.run.sim_driver import drive

    monkeypatch.setattr("hlcmp_drake.run.sim_driver.START_COMMAND_GUARD_S", 0.0)
    scenario, _ = load_scenario("insertion", ["duration_s=1.0"])
    lcm = DrakeLcm("memq://")
    driver = SimulatedIiwaDriver(scenario, lcm)
    _client_signalling(lcm, scenario, at_utime=30_000, number=number)
    summary = drive(driver, lcm, idle_timeout_s=5.0)
    # signalled before the answer to t = 30 ms came in: the steps to there, none after
    assert summary.interrupted and summary.stopped_because == f"{name} at t = 0.030 s"
    assert summary.steps == summary.commanded_steps == 30
    assert _handlers() == OWN_HANDLERS  # put back


@STOPPING
def test_ctrl_c_or_sigterm_before_any_command_stops_both_drivers_alike(own_handlers, number, name):
    from hlcmp_drake.run.drake_driver import DrakeDrivenWorld
    from hlcmp_drake.run.sim_driver import drive

    scenario, _ = load_scenario("insertion", ["duration_s=1.0"])
    # Each driver built before the timer starts: a signal before `drive` took it would end
    # the test session.
    lcm = DrakeLcm("memq://")
    driver = SimulatedIiwaDriver(scenario, lcm)
    threading.Timer(0.2, signal.raise_signal, [number]).start()
    summary = drive(driver, lcm, first_command_timeout_s=10)
    assert summary.interrupted and summary.steps == 0
    assert summary.stopped_because == f"{name} at t = 0.000 s, before any command"
    lcm = DrakeLcm("memq://")
    world = DrakeDrivenWorld(scenario, lcm, 0.005)
    threading.Timer(0.2, signal.raise_signal, [number]).start()
    drake = world.run(first_command_timeout_s=10)
    assert drake.interrupted and drake.commands == 0
    assert drake.stopped_because.endswith(" s, before any command")
    assert drake.stopped_because.startswith(f"{name} at t = 0.")
    assert _handlers() == OWN_HANDLERS


def test_a_second_ctrl_c_ends_the_driver_at_once(monkeypatch, own_handlers):
    """The first asks the loop to stop between two steps; a second, come before it did,
    ends the command as a Ctrl-C does (here, from within the step that took the first)."""
    from hlcmp_drake.run.sim_driver import drive

    monkeypatch.setattr("hlcmp_drake.run.sim_driver.START_COMMAND_GUARD_S", 0.0)
    scenario, _ = load_scenario("insertion", ["duration_s=1.0"])
    lcm = DrakeLcm("memq://")

    def twice(utime):
        if utime == 30_000:
            signal.raise_signal(signal.SIGTERM)
            signal.raise_signal(signal.SIGINT)

    answering_client(lcm, scenario, until_utime=10**12, on_answer=twice)
    with pytest.raises(KeyboardInterrupt):
        drive(SimulatedIiwaDriver(scenario, lcm), lcm, idle_timeout_s=5.0)
    assert _handlers() == OWN_HANDLERS


@STOPPING
def test_sim_driver_on_ctrl_c_or_sigterm_prints_its_summary_and_exits_130(
    monkeypatch, own_handlers, number, name
):
    """It writes no file, so nothing is said of files: the summary on stdout and one line
    on stderr, naming the signal as `hlcmp serve` does."""
    from conftest import run_cli

    monkeypatch.setattr("hlcmp_drake.run.sim_driver.START_COMMAND_GUARD_S", 0.0)
    scenario, _ = load_scenario("insertion")

    def open_lcm(url):
        lcm = DrakeLcm("memq://")
        _client_signalling(lcm, scenario, at_utime=30_000, number=number)
        return lcm

    monkeypatch.setattr("hlcmp_drake.run.sim_driver.open_lcm", open_lcm)
    result = run_cli("sim-driver", "insertion", "--lcm", UDPM, "--quiet")
    assert result.returncode == 130
    assert result.stdout.startswith("sim-driver: 30 steps (30 commanded, 0 held), 0.030 s ")
    assert result.stdout.strip().endswith(f"; {name} at t = 0.030 s")
    assert result.stderr == f"hlcmp sim-driver: interrupted: {name} at t = 0.030 s\n"
    delayed = run_cli("sim-driver", "insertion", "--lcm", UDPM, "--quiet", "--command-delay", "100")
    assert delayed.returncode == 130
    assert delayed.stdout.startswith("sim-driver: 30 steps (0 commanded, 0 held, 30 waiting ")
    # stopped by the user, not by the run's end: the delay is not said to be too long
    assert delayed.stdout.strip().endswith(
        f"; {name} at t = 0.030 s; no command acted: stopped within --command-delay 100 "
        "(0.1 s of plant steps)"
    )
