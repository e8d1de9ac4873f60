"""`hlcmp serve`: a scenario's controller as a torque-only client of the iiwa driver's LCM
protocol -- the same controller a run simulates, for drake-iiwa-driver on a real arm or
for `hlcmp sim-driver`.

Every status is answered with one tick of the fast path's tick (`worlds.arm.fast_tick`:
`ControlTick`, or `PoseControlTick` for a 6-D controller), the function the simulated
runs evaluate once per plant step: the task-space terms at the measured state, the law
(Hl-CMP learning online, a constant impedance, or a frozen skill), the torque below the
task, the saturation at the effort limits. The driver compensates gravity itself, so the
command is that torque minus G(q). θ takes the same explicit-Euler step as in the fast
path, θ += Δt θ', with Δt between the statuses' time stamps. The reference (the position
DMP's, and a 6-D controller's orientation) is the fast path's own source, simulated alone
and sampled at the ticks.

Watchdogs stop commanding (the driver then holds the arm) with the reason in serve.json:
no status for `iiwa_driver.stale_status_s`, a non-finite value in a status or a command,
and the run's own safety checks (a joint beyond its limit, a contact force above the
task's maximum, torques saturated for longer than `task.max_saturation_s`). The arm must
start at the scenario's start posture.
"""

from __future__ import annotations

import contextlib
import dataclasses as dc
import gc
import math
import operator
import os
import time
from collections import Counter, deque
from pathlib import Path
from typing import Callable, Iterator, Sequence

import numpy as np
from pydrake.lcm import DrakeLcm
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable

from hlcmp_drake.config.scenario import IiwaDriverConfig, Scenario
from hlcmp_drake.experiments import experiment_of
from hlcmp_drake.io import outputs
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.iiwa_lcm import (
    ProtocolError,
    decode_wrench,
    encode_torque_command,
    open_lcm,
    read_status_state,
    status_stamp,
)
from hlcmp_drake.io.runs import RunResult
from hlcmp_drake.io.skill import Skill
from hlcmp_drake.present.progress import SILENT, Progress
from hlcmp_drake.run.interrupts import StopSignals
from hlcmp_drake.run.learning import learning_scenario, replayed_reference_problem
from hlcmp_drake.run.runner import evaluate, experiment_worlds, without_claims, write_results
from hlcmp_drake.run.sim_driver import DriverSummary, SimulatedIiwaDriver
from hlcmp_drake.systems.monitor import plant_state_check
from hlcmp_drake.worlds.arm import ArmSetup, add_fast_reference, arm_check, fast_tick, prepare
from hlcmp_drake.worlds.build import driven_world_of
from hlcmp_drake.worlds.common import sample_reference
from hlcmp_drake.worlds.controllers import controller_kind, initial_theta
from hlcmp_drake.worlds.controllers import learners as learning_controllers
from hlcmp_drake.worlds.models import load_models, scoped_frame
from hlcmp_drake.worlds.pose import LOGGED_REFERENCE

# The statuses a served run may end with: "ok" (served its duration), "unstable" (a
# safety watchdog), "stopped" (the driver or the wrist sensor went quiet, or sent something
# unreadable), "degraded" (served to the end, missing too many ticks), "interrupted" (the
# user stopped it, Ctrl-C or SIGTERM: what was served up to then is written all the same).
FINISHED, UNSAFE, STOPPED, DEGRADED = "ok", "unstable", "stopped", "degraded"
INTERRUPTED = "interrupted"
# Steps between statuses the period is measured over before a mismatch is called: the
# smallest of them is the period unless every one spans a lost datagram.
PERIOD_EVIDENCE_STEPS = 10
# Statuses with no newer stamp, over stale_status_s, before a driver counts as taking no
# commands: one at 1 kHz sends 50; a status repeated after a slow tick, or a lockstep
# driver's resend of an unanswered status (every 20 ms), is no such evidence.
STUCK_EVIDENCE_STATUSES = 10
# The client's own commands it keeps to recognize when they come back on the command
# channel (LCM hands a process what it published): any other command there is another
# client's. A command not back after this many newer ones is taken as lost.
OWN_COMMANDS_KEPT = 64


def served_scenario(
    scenario: Scenario,
    controller: str | None = None,
    skill: Skill | None = None,
    freeze: bool = False,
    skill_path: str | Path | None = None,
    any_scenario: bool = False,
    warn: Callable[[str], None] | None = None,
) -> tuple[Scenario, str, tuple | None]:
    """The scenario and the controller to serve, and a skill's weights to start from.

    Parameters
    ----------
    scenario : Scenario
        An arm scenario.
    controller : str, optional
        Its label (default: the scenario's Hl-CMP, else its first controller; with a
        skill, the learner to serve it with).
    skill : Skill, optional
        Serve the scenario's Hl-CMP with this skill's DMP settings and learned weights.
    freeze : bool
        With a skill: no adaptation (learning rates 0).
    skill_path : str or Path, optional
        The skill's file, named when it does not fit (`run.learning.learning_scenario`).
    any_scenario : bool
        Serve a skill learned in another world all the same (`run.learning.check_skill_world`,
        after the checks that no skill could pass: an arm, a demonstration, a learner).
    warn : callable(str), optional
        Given the skill's world's warning, when there is one.

    Returns
    -------
    scenario : Scenario
        As served (reduced to the Hl-CMP for a skill).
    controller : str
        The served controller's label.
    theta0 : tuple of arrays or None
        The skill's weights (`Skill.theta`: three (M, N), then three (3, N) for a 6-D one).

    Raises
    ------
    InputError
        For a scenario without an arm, a status period longer than the run, an unknown
        label, a controller that has no one-tick law (a variable impedance), or a skill that
        does not fit or, without `any_scenario`, was learned in another world.
    """
    driven_world_of(scenario, "hlcmp serve drives an iiwa")
    period = scenario.iiwa_driver.period_s
    if period > scenario.duration_s:
        raise InputError(
            f"iiwa_driver.period_s: a status every {period:g} s is longer than the whole run "
            f"served ({scenario.duration_s:g} s, --duration or duration_s): it would be one tick"
        )
    if skill is not None:
        scenario = learning_scenario(
            scenario,
            skill=skill,
            freeze=freeze,
            controller=controller,
            skill_path=skill_path,
            any_scenario=any_scenario,
            warn=warn,
        )
        controller = next(iter(scenario.controllers))
        return scenario, controller, skill.theta
    if freeze:
        raise InputError(
            "--freeze needs --skill: a frozen skill is served with the profiles it learned"
        )
    learners = learning_controllers(scenario)
    controller = controller or (learners[0] if learners else next(iter(scenario.controllers)))
    if controller not in scenario.controllers:
        raise InputError(
            f"--controller: scenario '{scenario.name}' has no controller '{controller}' "
            f"(it has {', '.join(scenario.controllers)})"
        )
    kind = controller_kind(scenario, controller)
    if kind.law is None or kind.uses_contact_force:
        raise InputError(
            f"--controller: '{controller}' ({type(scenario.controllers[controller]).__name__}) "
            "has no one-tick law to serve; serve an Hl-CMP or a constant impedance"
        )
    return scenario, controller, None


@dc.dataclass
class ServeResult:
    """What `serve` returns: the run as logged, the serve.json content, and where the files went."""

    run: RunResult
    record: dict
    metrics: dict
    out_dir: Path | None


class TorqueClient:
    """One controller answering an iiwa driver's statuses with torques.

    Parameters
    ----------
    scenario : Scenario
        An arm scenario; `iiwa_driver` says the channels, the force source and the watchdogs.
    controller : str
        The label of the controller to serve (see `served_scenario`).
    lcm : DrakeLcm
        Where to subscribe and publish.
    theta0 : tuple of three (M, N) arrays, optional
        A learner's initial weights (a skill's).
    setup : ArmSetup, optional
        The DMP and start posture (default: `prepare(scenario)`, as a run would).
    """

    def __init__(
        self,
        scenario: Scenario,
        controller: str,
        lcm: DrakeLcm,
        theta0: tuple | None = None,
        setup: ArmSetup | None = None,
    ):
        self.scenario, self.controller = scenario, controller
        self.config = scenario.iiwa_driver
        self.duration = scenario.duration_s  # served from the first command, as a run simulates it
        self._lcm = lcm
        setup = setup or prepare(scenario)
        self.q0 = setup.q0
        # The controller's own model of the arm: the same model files as the world's.
        plant = MultibodyPlant(0.0)
        load_models(plant, scenario)
        self.plant = plant
        self.tick = fast_tick(scenario, controller, plant=plant, setup=setup)
        self.law = self.tick.law
        self.theta = (
            initial_theta(scenario.controllers[controller], scenario, theta0)
            if self.law.learns
            else None
        )
        self._rate = None
        self._tool = scoped_frame(plant, scenario.task.tool_frame)
        self._axes = list(scenario.task.axes)
        self.nq, self.nv = plant.num_positions(), plant.num_velocities()
        ports = [name for name, _ in self.tick.reference_ports]
        self._reference = sample_reference(
            scenario,
            lambda builder: add_fast_reference(builder, scenario, controller, setup),
            ports,
            self.config.period_s,
            self.duration,
        )
        # The sampled reference logged as the simulated run logs it: x_d, and a 6-D
        # controller's R_d.
        self._logged_reference = {
            series: ports.index(port)
            for port, series in {"desired_position": "xd", **LOGGED_REFERENCE}.items()
            if port in ports
        }
        # One tick at the start posture before any status: a compiled tick compiles (or loads
        # from numba's cache) its kernels on its first call, which takes seconds.
        _ = self.tick.evaluate(
            np.concatenate([self.q0, np.zeros(plant.num_velocities())]),
            tuple(values[0] for values in self._reference),
            self.theta,
        ).law.rates
        self._log_every = max(1, int(round(scenario.log_period_s / self.config.period_s)))
        self._next_check_k = 0  # the tick index from which the next 100 Hz check is due
        self._state_check = plant_state_check(self.nq, scenario.max_abs_position_m)
        self._safety = arm_check(plant, scenario.task)
        # As arm_check tolerates; as floats, which the tick compares without an array.
        self._lower = (plant.GetPositionLowerLimits() - 1e-3).tolist()
        self._upper = (plant.GetPositionUpperLimits() + 1e-3).tolist()
        self._wrist = None
        self._wrist_wall: float | None = None  # when the last wrench came
        self._force_world, self._torque_tool = np.zeros(3), np.zeros(3)
        self._latest = None  # (received at, status bytes) not yet answered
        # The warm-up's state: the last answered status's tick inputs and stamp, the stamp
        # it warmed up after, the driver's clock in this one (the least delay seen from a
        # stamp to its receipt, let grow by 1 µs a status to follow a drift), and, while
        # it runs, when the client stopped listening.
        self._warm_inputs: tuple | None = None
        self._answered_stamp: int | None = None
        self._warmed_after: int | None = None
        self._stamp_offset_s: float | None = None
        self._deaf_since: float | None = None
        self.warm_up_overlaps = 0
        self.first_status_wall = None
        self.last_status_wall = None
        # The newest stamp received, and when a status last brought a newer one: a driver
        # that sends statuses without advancing its stamp takes no commands.
        self._newest_stamp: int | None = None
        self._advanced_wall: float | None = None
        self._statuses_since_advance = 0
        self._utime0 = self._last_utime = None
        self._last_command = None
        self._own_commands: Counter[bytes] = Counter()  # published, not yet come back
        self._own_order: deque[bytes] = deque()
        self.ticks = self.missed_ticks = 0
        self.longest_missed_run = 0
        # The status period as the driver's stamps say, from the steps between two
        # statuses received one after the other, each read as it comes, whether answered
        # or not (a status lost only makes a step longer; a burst of statuses queued
        # while the client was busy makes none). The check against the configured period
        # takes the shortest step; the period reported is the median of the steps with
        # no status lost between them, since a driver that stamps µs truncated from its
        # clock steps by 4999 and 5001 among its 5000.
        self._shortest_step_s: float | None = None
        self._step_counts: Counter[int] = Counter()
        self._previous_stamp: int | None = None
        self._stamp_steps = 0
        self.tick_seconds: list[float] = []
        self.log_t: list[float] = []
        # The tick's log column -> its series name: the law's, then the tick's own extras
        # (a 6-D tick's tau_c and tool orientation).
        self._tick_series = {
            **controller_kind(scenario, controller).logs,
            **self.tick.extra_series,
        }
        self.log_rows: dict[str, list] = {
            name: []
            for name in (
                "x",
                "f_ext",
                "tau_ext",
                "fc",
                "plant_state",
                "saturated_joints",
                *self._logged_reference,
                *self._tick_series.values(),
            )
        }
        self.stopped_because: str | None = None
        self.status = FINISHED
        lcm.Subscribe(self.config.status_channel, self._on_status)
        # Another client's commands are looked for at the 100 Hz checks, on a listener of
        # their own, so that this client's commands coming back do not wake its wait for
        # the next status every tick (memq:// reaches only this process: its one bus).
        url = lcm.get_lcm_url()
        self._command_listener = lcm if url.startswith("memq://") else DrakeLcm(url)
        self._command_listener.Subscribe(self.config.command_channel, self._on_command)
        if self.config.force_source == "wrist_sensor":
            lcm.Subscribe(self.config.wrist_channel, self._on_wrench)

    @property
    def done(self) -> bool:
        """Whether the client has stopped commanding (finished or a watchdog)."""
        return self.stopped_because is not None

    def _on_status(self, data: bytes) -> None:
        now = time.perf_counter()
        self.last_status_wall = now
        self.first_status_wall = self.first_status_wall or now
        stamp = status_stamp(data)
        if stamp is not None and (self._newest_stamp is None or stamp > self._newest_stamp):
            self._newest_stamp, self._advanced_wall = stamp, now
            self._statuses_since_advance = 0
        else:
            self._statuses_since_advance += 1
        if stamp is not None:
            offset = now - stamp / 1e6
            previous = self._stamp_offset_s
            self._stamp_offset_s = offset if previous is None else min(previous + 1e-6, offset)
        if self._deaf_since is not None:  # it came during a warm-up: it waited since then
            self.warm_up_overlaps += 1
            now = self._deaf_since
        self._latest = (now, data)
        self._measure_period(stamp)

    def _publish(self, command: bytes) -> None:
        """Send a command, then keep it to recognize it when it comes back (`_on_command`:
        called from `HandleSubscriptions` only, never while this runs)."""
        self._lcm.Publish(self.config.command_channel, command)
        self._own_commands[command] += 1
        self._own_order.append(command)
        if len(self._own_order) > OWN_COMMANDS_KEPT:
            lost = self._own_order.popleft()
            self._own_commands[lost] -= 1
            if not self._own_commands[lost]:
                del self._own_commands[lost]

    def _hear_other_clients(self) -> None:
        """Read the commands come on the command channel since the last look (on memq:// the
        client's own bus has handed them over already)."""
        if self._command_listener is not self._lcm:
            self._command_listener.HandleSubscriptions(0)

    def _on_command(self, data: bytes) -> None:
        """A command on the command channel: one of this client's, back, or another
        client's, which stops this one: two controllers must not drive one arm (each
        would read the other's torques as the arm's response)."""
        if self._own_commands[data]:
            self._own_commands[data] -= 1
            return
        self.stop(
            STOPPED,
            f"another client commands the arm on {self.config.command_channel} "
            f"(iiwa_driver.command_channel) at t = {self.served_time():.3f} s; one arm takes "
            "one controller's commands",
        )

    @property
    def pending(self) -> bool:
        """Whether a status has come that the next `poll` answers."""
        return self._latest is not None

    def warm_up(self) -> None:
        """With a warm-up lead > 0 (`IiwaDriverConfig.warm_up_lead`), once per answered
        status: listen until that long before the next status is expected (the answered
        one's stamp plus `period_s`, on the driver's clock as the stamps' receipts place
        it), then run one throw-away tick
        at the answered status's inputs, so that the next tick starts from warm caches, and
        poll for the status without sleeping until it comes, at most `warm_up_poll` after
        it is expected. A status that comes first is left for `poll`; one that comes
        during the warm-up counts as received when the client stopped listening
        (`warm_up_overlaps`)."""
        lead = self.config.warm_up_lead()
        if not lead or self._warm_inputs is None or self._warmed_after == self._answered_stamp:
            return
        self._warmed_after = self._answered_stamp
        expected = self._answered_stamp / 1e6 + self.config.period_s + self._stamp_offset_s
        wake = expected - lead
        # Listening all the while (LCM waits in whole milliseconds, so the warm-up starts
        # up to 1 ms after `wake`): the client is deaf only while the warm-up runs.
        while not self.pending and time.perf_counter() < wake:
            self._lcm.HandleSubscriptions(1)
        if self.pending:
            return
        self._deaf_since = time.perf_counter()
        try:
            state, reference, theta = self._warm_inputs
            self.tick.evaluate(state, reference, theta)
            self._lcm.HandleSubscriptions(0)  # what came meanwhile
        finally:
            self._deaf_since = None
        # Polling, not sleeping, from here to the status: its tick then starts on a core
        # that has not gone idle (`IiwaDriverConfig.warm_up_poll`).
        until = expected + self.config.warm_up_poll()
        while not self.pending and time.perf_counter() < until:
            self._lcm.HandleSubscriptions(0)

    def _measure_period(self, utime: int | None) -> None:
        """Take the step from the previous status's stamp into the measured period."""
        if utime is None:
            return  # not a status: decoding the newest says so
        previous, self._previous_stamp = self._previous_stamp, utime
        if previous is None or utime <= previous:
            return  # the first, a duplicate or an older status: no step to measure
        step = utime - previous
        self._step_counts[step] += 1
        self._shortest_step_s = (
            step / 1e6 if self._shortest_step_s is None else min(self._shortest_step_s, step / 1e6)
        )
        self._stamp_steps += 1

    @property
    def status_period_s(self) -> float | None:
        """The median of the steps between the stamps of statuses received one after the
        other with none lost between them (shorter than 1.5 times the shortest) [s]; None
        before two have come."""
        if not self._step_counts:
            return None
        steps = sorted(self._step_counts)
        steps = [step for step in steps if step < 1.5 * steps[0]]
        half, seen = sum(self._step_counts[step] for step in steps) / 2, 0
        for step in steps:
            seen += self._step_counts[step]
            if seen >= half:
                break
        return step / 1e6

    def _on_wrench(self, data: bytes) -> None:
        self._wrist, self._wrist_wall = data, time.perf_counter()

    def stop(self, status: str, reason: str) -> None:
        """Stop commanding from now on.

        Parameters
        ----------
        status : str
            FINISHED, UNSAFE, STOPPED or INTERRUPTED.
        reason : str
            Why, for serve.json.
        """
        if self.stopped_because is None:
            self.status, self.stopped_because = status, reason

    def poll(self) -> None:
        """Answer the newest status received since the last poll (an older one not yet
        answered is skipped and counted as missed), and check that statuses still come."""
        if self.done or self._stamps_stuck():
            return
        if self._latest is None:
            if (
                self.last_status_wall is not None
                and time.perf_counter() - self.last_status_wall > self.config.stale_status_s
            ):
                self.stop(
                    STOPPED,
                    f"no status for {self.config.stale_status_s * 1000:.0f} ms (stale) "
                    f"at t = {self.served_time():.3f} s",
                )
            return
        received, data = self._latest
        self._latest = None
        try:
            status = read_status_state(data, self.nv)
        except ProtocolError as error:
            self.stop(STOPPED, f"the driver sent {error}")
            return
        if self._period_mismatch():
            return
        self._answer(*status, received)

    def _stamps_stuck(self) -> bool:
        """Stop (True) when, since the first command, statuses keep coming (at least
        STUCK_EVIDENCE_STATUSES) but none has advanced the driver's stamp for
        `stale_status_s`: the driver is not taking the commands (a driver paced by its
        client stamps each status a period later only once it has applied the command
        that answered the last)."""
        stale = self.config.stale_status_s
        now = time.perf_counter()
        if (
            self._utime0 is None
            or self._statuses_since_advance < STUCK_EVIDENCE_STATUSES
            or now - self._advanced_wall <= stale
            or now - self.last_status_wall > stale  # no status at all: `poll` says so
        ):
            return False
        self.stop(
            STOPPED,
            f"the driver's statuses kept coming but none newer than utime "
            f"{self._newest_stamp} for {stale * 1000:.0f} ms from t = "
            f"{self.served_time():.3f} s: it takes no command on "
            f"{self.config.command_channel} (iiwa_driver.command_channel), or it restarted?",
        )
        return True

    def _period_mismatch(self) -> bool:
        """Stop (True) when the measured status period is not the configured one, since
        the reference is sampled and θ stepped at `period_s`."""
        configured = self.config.period_s
        if self._stamp_steps < PERIOD_EVIDENCE_STEPS or abs(self._shortest_step_s - configured) <= (
            self.config.period_tolerance * configured
        ):
            return False
        period = self.status_period_s
        self.stop(
            STOPPED,
            f"the driver's statuses come every {period * 1000:g} ms (their "
            f"stamps), iiwa_driver.period_s is {configured * 1000:g} ms: set --set "
            f"iiwa_driver.period_s={period:g}",
        )
        return True

    def assess(self) -> None:
        """After serving: a run that finished but missed more ticks than
        `max_missed_fraction` of its duration's, or `max_consecutive_missed` in a row, is
        DEGRADED, with the numbers in its reason."""
        if self.status != FINISHED:
            return
        config = self.config
        total = self.ticks + self.missed_ticks
        fraction = self.missed_ticks / total if total else 0.0
        if fraction > config.max_missed_fraction:
            self.status = DEGRADED
            self.stopped_because = (
                f"missed {self.missed_ticks} of {total} ticks ({100 * fraction:.1f} %), above "
                f"iiwa_driver.max_missed_fraction = {100 * config.max_missed_fraction:g} %"
            )
        elif self.longest_missed_run >= config.max_consecutive_missed:
            self.status = DEGRADED
            self.stopped_because = (
                f"missed {self.longest_missed_run} ticks in a row, at least "
                f"iiwa_driver.max_consecutive_missed = {config.max_consecutive_missed}"
            )

    def served_time(self) -> float:
        """The time served from the first command to the last answered status [s]."""
        return 0.0 if self._last_utime is None else (self._last_utime - self._utime0) / 1e6

    def _answer(
        self, utime: int, position: tuple, velocity: tuple, torque_external: tuple, received: float
    ) -> None:
        """Command the torque for one status (its fields as `read_status_state` gives them):
        until the command is out, plain floats rather than arrays wherever the numbers
        allow, and one array made, the tick's state."""
        if not all(map(math.isfinite, position + velocity + torque_external)):
            self.stop(UNSAFE, f"a non-finite value in the status at utime {utime}")
            return
        if self._utime0 is None:
            if not self._ready_to_start(position, utime, received):
                return
        elif utime == self._last_utime and self._last_command is not None:
            self._publish(self._last_command)  # its answer was lost
            return
        elif utime < self._last_utime:
            return  # older than one already answered
        state = np.array(position + velocity)
        t = (utime - self._utime0) / 1e6
        k = int(round(t / self.config.period_s))
        last = len(self._reference[0]) - 1  # the tick at the duration
        if self._last_utime is not None:
            # Statuses between the last answered one and this one (up to the duration) went
            # unanswered.
            previous = int(round((self._last_utime - self._utime0) / 1e6 / self.config.period_s))
            gap = max(0, min(k, last + 1) - previous - 1)
            self.missed_ticks += gap
            self.longest_missed_run = max(self.longest_missed_run, gap)
        if k > last:
            self.stop(FINISHED, f"served {self.duration:g} s")
            return
        if self._last_utime is not None and self._rate is not None:
            # θ' held for one period after the tick that computed it: the explicit-Euler step
            # of the fast path. Over statuses missed in between no rate was computed, so a
            # gap is not integrated as if it were one long step of the old rate.
            step = min((utime - self._last_utime) / 1e6, self.config.period_s)
            self.theta = self.theta + step * self._rate
        reference = tuple([values[k] for values in self._reference])
        result = self.tick.evaluate(state, reference, self.theta)
        command = result.torque - result.joint_gravity  # the driver adds G(q) itself
        torques = command.tolist()
        # A non-finite command or a joint past its limit withholds this tick's command.
        if (
            not all(map(math.isfinite, torques))
            or any(map(operator.lt, position, self._lower))
            or any(map(operator.gt, position, self._upper))
        ):
            self._check(t, torque_external, state, command, result)
            return
        self._last_command = encode_torque_command(utime, position, torques)
        self._publish(self._last_command)
        self.tick_seconds.append(time.perf_counter() - received)
        self.ticks += 1
        self._warm_inputs, self._answered_stamp = (state, reference, self.theta), utime
        self._last_utime = utime
        self._rate = result.law.rates
        # The simulated run's monitor and loggers read the wrist force at 100 Hz; so does this,
        # after the command is out: a problem found stops the next command. At the first
        # answered tick from each log period on, not only at ticks on the period's grid: a
        # client that falls behind and answers every other status would otherwise skip the
        # checks, and the listener that tells its own commands from another client's.
        if k >= self._next_check_k:
            self._next_check_k = (k // self._log_every + 1) * self._log_every
            self._hear_other_clients()
            if self._check(t, torque_external, state, command, result):
                self._log(t, k, state, result)
        if k >= len(self._reference[0]) - 1 and not self.done:
            self.stop(FINISHED, f"served {self.duration:g} s")

    def _ready_to_start(self, position: tuple, utime: int, received: float) -> bool:
        """Before the first command: the arm must be at the start posture, and the driver's
        start guard must have passed."""
        off = np.abs(np.array(position) - self.q0)
        if off.max() > self.config.start_tolerance_rad:
            joint = int(np.argmax(off))
            self.stop(
                STOPPED,
                f"the arm is not at the scenario's start posture: joint {joint + 1} is "
                f"{off[joint]:.3f} rad away (iiwa_driver.start_tolerance_rad = "
                f"{self.config.start_tolerance_rad}); move it to q0 = "
                f"{np.round(self.q0, 3).tolist()}",
            )
            return False
        self._hear_other_clients()  # one already commanding: this one never starts
        if self.done or received - self.first_status_wall < self.config.start_guard_s:
            return False
        if self.config.force_source == "wrist_sensor" and self._wrist is None:
            self.stop(
                STOPPED,
                f"no wrench on {self.config.wrist_channel} during the start guard "
                f"({self.config.start_guard_s:g} s): is the wrist F/T sensor publishing there "
                "(iiwa_driver.wrist_channel)? Without it no contact force is checked; "
                "--set iiwa_driver.force_source=external_torque reads the driver's external "
                "torques instead",
            )
            return False
        self._utime0 = utime
        self._advanced_wall, self._statuses_since_advance = received, 0
        return True

    def _wrist_wrench(self, torque_external: tuple) -> tuple[np.ndarray, np.ndarray]:
        """The environment's force on the tool, world frame [N], and its torque about the
        tool point, tool frame [N m], from the configured source. The tick has just set the
        controller plant's context to the status's positions."""
        context = self.tick.model.context
        rotation = self._tool.CalcRotationMatrixInWorld(context)
        if self.config.force_source == "external_torque":
            world = self.plant.world_frame()
            jacobian = self.plant.CalcJacobianSpatialVelocity(
                context, JacobianWrtVariable.kV, self._tool, np.zeros(3), world, world
            )
            # The wrench [τ; f] at the tool point, world, whose J^T is the external torque.
            wrench = np.linalg.lstsq(jacobian.T, np.array(torque_external), rcond=None)[0]
            return wrench[3:], rotation.inverse() @ wrench[:3]
        if self._wrist is None:  # no sensor: `_check` stops the run
            return np.zeros(3), np.zeros(3)
        _, force_tool, torque_tool = decode_wrench(self._wrist)
        return rotation @ force_tool, torque_tool

    def _check(self, t, torque_external, state, command, result) -> bool:
        """The run's safety checks (`arm_check` and the plant-state check) on this tick;
        False, and the client stopped, at a problem. Keeps the wrist wrench for the log."""
        self._force_world, self._torque_tool = self._wrist_wrench(torque_external)
        problem = self._state_check(state)
        if problem is None and not np.all(np.isfinite(command)):
            problem = "a non-finite torque command"
        problem = problem or self._safety(
            t,
            {
                "plant_state": state,
                "contact_force": self._force_world,
                "saturated": [result.saturated],
            },
        )
        if problem is not None:
            self.stop(UNSAFE, f"{problem} at t = {t:.3f} s")
            return False
        quiet = self._wrench_stale()
        if quiet is not None:  # a sensor gone quiet, as a driver gone quiet: stopped
            self.stop(STOPPED, f"{quiet} at t = {t:.3f} s")
        return quiet is None

    def _wrench_stale(self) -> str | None:
        """Why the wrist wrench cannot be checked: none for `stale_wrench_s` from the
        wrist sensor (the force source), which went quiet."""
        stale = self.config.stale_wrench_s
        if self.config.force_source != "wrist_sensor" or (
            self._wrist_wall is not None and time.perf_counter() - self._wrist_wall <= stale
        ):
            return None
        return (
            f"no wrench on {self.config.wrist_channel} for {stale * 1000:.0f} ms (the wrist "
            "F/T sensor went quiet: the contact force is not checked)"
        )

    def _log(self, t, k, state, result) -> None:
        row = self.tick.log_row(result)
        columns = self.tick.log_columns
        self.log_t.append(t)
        logs = self.log_rows
        logs["x"].append(row[columns["position"]])
        logs["f_ext"].append(self._force_world[self._axes])
        logs["tau_ext"].append(self._torque_tool)
        logs["fc"].append(row[columns["force"]])
        logs["plant_state"].append(state)
        logs["saturated_joints"].append(row[columns["saturated"]])
        for series, port in self._logged_reference.items():
            logs[series].append(self._reference[port][k])
        for field, series in self._tick_series.items():
            logs[series].append(row[columns[field]])

    def run_result(self) -> RunResult:
        """The served run as a RunResult, the same series a simulated run logs.

        Returns
        -------
        RunResult
            Status "ok", "unstable" (a safety watchdog) or "stopped" (the driver).
        """
        series = {
            name: np.array(rows, dtype=float).reshape(len(rows), -1) if rows else np.zeros((0, 0))
            for name, rows in self.log_rows.items()
        }
        theta = self.law.unflatten(self.theta) if self.theta is not None else None
        stop_time = None if self.status == FINISHED else self.served_time()
        return RunResult(
            self.controller,
            np.array(self.log_t),
            series,
            self.status,
            "" if self.status == FINISHED else self.stopped_because,
            stop_time,
            theta,
        )

    def record(self, lcm_url: str) -> dict:
        """The serve.json content.

        Parameters
        ----------
        lcm_url : str
            Where it served.

        Returns
        -------
        dict
            ticks, missed_ticks, tick_us (p50, p99, max: from a status's receipt to its
            command's publication), warm_up_overlaps (statuses that came during a
            warm-up), stopped_because, and what was served where.
        """
        micros = np.array(self.tick_seconds) * 1e6
        percentiles = (
            {
                "p50": float(np.percentile(micros, 50)),
                "p99": float(np.percentile(micros, 99)),
                "max": float(micros.max()),
            }
            if micros.size
            else {"p50": None, "p99": None, "max": None}
        )
        return {
            "scenario": self.scenario.name,
            "controller": self.controller,
            "lcm_url": lcm_url,
            "force_source": self.config.force_source,
            "period_s": self.config.period_s,
            "status_period_s": self.status_period_s,
            "warm_up_lead_s": self.config.warm_up_lead(),
            "warm_up_poll_s": self.config.warm_up_poll(),
            "warm_up_overlaps": self.warm_up_overlaps,
            "realtime_priority": served_priority(self.config, lcm_url),
            "ticks": self.ticks,
            "missed_ticks": self.missed_ticks,
            "longest_missed_run": self.longest_missed_run,
            "tick_us": percentiles,
            "served_s": self.served_time(),
            "status": self.status,
            "stopped_because": self.stopped_because,
        }


def serve(client: TorqueClient, lcm: DrakeLcm, lcm_url: str, reporter: Progress = SILENT) -> None:
    """Answer statuses until the client finishes or a watchdog stops it.

    Parameters
    ----------
    client : TorqueClient
    lcm : DrakeLcm
        The one the client subscribed on.
    lcm_url : str
        For the messages.
    reporter : Progress, optional
    """
    config = client.config
    reporter.say(f"serve: {client.controller} waiting for {config.status_channel} at {lcm_url}")
    start = time.perf_counter()
    with without_garbage_collection(), interruptible(client):
        while not client.done:
            client.warm_up()  # with iiwa_driver.warm_up_lead_s; may take the next status
            # Sleep until a status comes: polling without sleeping (busy_wait) starts the
            # tick from warm caches, but starves LCM's receiving of the CPU, and it loses
            # datagrams then (docs/iiwa.md).
            polling = config.busy_wait and client.first_status_wall is not None
            if not client.pending:
                lcm.HandleSubscriptions(0 if polling else 10)
            client.poll()
            if (
                client.first_status_wall is None
                and time.perf_counter() - start > config.first_status_timeout_s
            ):
                client.stop(
                    STOPPED,
                    f"no status on {config.status_channel} at {lcm_url} within "
                    f"{config.first_status_timeout_s:g} s: is the driver running?",
                )
    client.assess()


def served_priority(config: IiwaDriverConfig, lcm_url: str) -> int:
    """The SCHED_FIFO priority the client serves at: `config.realtime_priority`, except
    over memq://, whose simulated driver runs in the client's own thread (0).

    Parameters
    ----------
    config : IiwaDriverConfig
    lcm_url : str
        Where it serves.

    Returns
    -------
    int
        0 (the normal scheduler) or 1-99.
    """
    return 0 if lcm_url.startswith("memq://") else config.realtime_priority


# Linux's budget for real-time threads: of every period, they may run for the runtime
# (-1: without limit); a SCHED_FIFO thread that never sleeps is stopped for the rest.
RT_RUNTIME_FILE = Path("/proc/sys/kernel/sched_rt_runtime_us")
RT_PERIOD_FILE = Path("/proc/sys/kernel/sched_rt_period_us")


def realtime_throttling() -> tuple[float, float] | None:
    """How long Linux stops a real-time thread that never sleeps, and in what period [ms]
    (kernel.sched_rt_period_us less kernel.sched_rt_runtime_us); None where it does not
    (a runtime of -1) or says nothing (no such files)."""
    try:
        runtime, period = (int(path.read_text()) for path in (RT_RUNTIME_FILE, RT_PERIOD_FILE))
    except (OSError, ValueError):
        return None
    return None if runtime < 0 else ((period - runtime) / 1000, period / 1000)


def check_served_priority(config: IiwaDriverConfig, lcm_url: str) -> None:
    """Before the client is made: the process may take its SCHED_FIFO priority
    (`realtime_scheduling`), and it does not poll without sleeping at it (`busy_wait`),
    which Linux's real-time throttling would stop for tens of milliseconds a second, more
    than a driver waits for a command (measured: docs/iiwa.md).

    Parameters
    ----------
    config : IiwaDriverConfig
        Its `realtime_priority` and `busy_wait`.
    lcm_url : str
        Where it will serve (`served_priority`).

    Raises
    ------
    InputError
        Naming the setting and what to change.
    """
    priority = served_priority(config, lcm_url)
    throttling = realtime_throttling() if priority and config.busy_wait else None
    if throttling is not None and throttling[0] > 0:
        stopped, period = throttling
        raise InputError(
            f"iiwa_driver.realtime_priority: with iiwa_driver.busy_wait the client never "
            f"sleeps, and Linux stops a SCHED_FIFO thread that never sleeps for {stopped:g} "
            f"ms of every {period:g} ms (kernel.sched_rt_runtime_us), missing every status "
            "meanwhile: set one of the two, or kernel.sched_rt_runtime_us to -1"
        )
    with realtime_scheduling(priority):
        pass  # refused here, in one line, if the process may not take it


@contextlib.contextmanager
def realtime_scheduling(priority: int) -> Iterator[None]:
    """This thread at SCHED_FIFO `priority` (`iiwa_driver.realtime_priority`), its own
    scheduling restored afterwards; nothing changes for 0.

    Parameters
    ----------
    priority : int
        0, or 1-99.

    Raises
    ------
    InputError
        When the process may not take that priority, naming the setting and how to grant it.
    """
    if not priority:
        yield
        return
    policy, parameters = os.sched_getscheduler(0), os.sched_getparam(0)
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
    except PermissionError as error:
        raise InputError(
            f"iiwa_driver.realtime_priority: this process may not run at SCHED_FIFO priority "
            f"{priority} ({error.strerror}): run it as root, with CAP_SYS_NICE, or with an "
            f"rtprio limit of at least {priority}; 0 serves on the normal scheduler"
        ) from None
    try:
        yield
    finally:
        os.sched_setscheduler(0, policy, parameters)


@contextlib.contextmanager
def without_garbage_collection() -> Iterator[None]:
    """No cyclic garbage collection while serving: a collection walks every object alive
    (Drake's bindings make many) and would stall a tick for milliseconds. A tick's own
    objects are freed by reference counting; the collector runs again afterwards."""
    gc.collect()
    gc.freeze()
    gc.disable()
    try:
        yield
    finally:
        gc.enable()
        gc.unfreeze()


def interruptible(client: TorqueClient) -> StopSignals:
    """Ctrl-C (SIGINT) or SIGTERM (`kill`, `timeout`, a service manager) while serving stops
    the client (INTERRUPTED, "SIGTERM at t = ...") instead of ending the command: on an arm
    it is how a run is stopped, and what was served up to then is written. The handler
    only marks the client stopped, so the loop ends between two ticks and no log is left
    half-appended (`StopSignals`).

    Parameters
    ----------
    client : TorqueClient
        The client the signals stop.

    Returns
    -------
    StopSignals
        To run the serving loop in, as a `with` block.
    """
    return StopSignals(
        lambda by: client.stop(INTERRUPTED, f"{by} at t = {client.served_time():.3f} s")
    )


def write_served(
    client: TorqueClient, out_dir: str | Path, lcm_url: str, served: dict | None = None
) -> ServeResult:
    """Evaluate the served run and write timeseries.npz, recording.html, metrics.json (as
    `hlcmp run` does, for the one controller: no claims, which compare controllers) and
    serve.json, each atomically.

    Parameters
    ----------
    client : TorqueClient
        After `serve`.
    out_dir : str or Path
    lcm_url : str
    served : dict, optional
        What was served, for serve.json beside the client's record (`serve_scenario`'s
        skill file, adaptation and overrides).

    Returns
    -------
    ServeResult
    """
    run = client.run_result()
    record = {**client.record(lcm_url), **(served or {})}
    out_dir = Path(out_dir)
    experiment = experiment_of(client.scenario)
    scenario = dc.replace(
        client.scenario,
        controllers={client.controller: client.scenario.controllers[client.controller]},
    )
    if len(run.t):
        metrics = evaluate({run.controller: run}, scenario, without_claims(experiment))
    else:  # no tick was logged: nothing to measure
        metrics = {"scenario": scenario.name, "controllers": {}, "learners": {}, "claims": {}}
    metrics["status"] = run.status
    with outputs.replacing_outputs(out_dir):
        if len(run.t):
            write_results(out_dir, scenario, {run.controller: run}, metrics, {})
        else:  # nothing was served: no series to write
            outputs.write_json(out_dir / "metrics.json", metrics)
        outputs.write_json(out_dir / "serve.json", record)
    return ServeResult(run, record, metrics, out_dir)


def lockstep(driver: SimulatedIiwaDriver, client: TorqueClient, lcm: DrakeLcm) -> DriverSummary:
    """Run a driver and its client in this process on one memq:// LCM, one message at a
    time: status, command, step. Wall time passes only for the start guards.

    Parameters
    ----------
    driver : SimulatedIiwaDriver
    client : TorqueClient
        Subscribed on the same `lcm`.
    lcm : DrakeLcm
        memq://, shared by both.

    Returns
    -------
    DriverSummary
    """
    start = time.perf_counter()
    steps = commanded = 0
    with without_garbage_collection(), interruptible(client):
        while not client.done:
            driver.publish_status()
            lcm.HandleSubscriptions(0)  # the status reaches the client
            client.poll()
            lcm.HandleSubscriptions(0)  # its command reaches the driver
            if driver.command is not None and driver.command[0] == driver.status_utime:
                commanded += driver.step(driver.command[1])
                steps += 1
            elif not client.done:
                time.sleep(driver.period)  # the start guards count wall time
    client.assess()
    return DriverSummary(
        steps,
        commanded,
        0,
        0,
        driver.time,
        time.perf_counter() - start,
        client.stopped_because,
        driver.command_delay_s,
    )


def serve_scenario(
    name_or_path: str | Path,
    lcm_url: str,
    out_dir: str | Path,
    *,
    controller: str | None = None,
    skill: Skill | None = None,
    skill_path: str | Path | None = None,
    freeze: bool = False,
    any_scenario: bool = False,
    overrides: Sequence[str] = (),
    reporter: Progress = SILENT,
    warn: Callable[[str], None] | None = None,
) -> ServeResult:
    """Load a scenario, serve its controller over LCM, and write the results.

    With a memq:// URL (which reaches only this process) the scenario's simulated driver
    runs here too, in lockstep with the client.

    Parameters
    ----------
    name_or_path : str or Path
        A bundled arm scenario or a YAML file.
    lcm_url : str
        Where the driver is.
    out_dir : str or Path
        Where timeseries.npz, metrics.json, recording.html and serve.json go.
    controller, skill, freeze
        What to serve (see `served_scenario`).
    skill_path : str or Path, optional
        Where `skill` was read from (recorded in serve.json, and named when it does not
        fit).
    any_scenario : bool
        Serve a skill learned in another world all the same (refused otherwise, before
        the LCM is opened: `run.learning.check_skill_world`).
    overrides : sequence of str
        ``dotted.key=value`` overrides (duration_s sets how long to serve).
    reporter : Progress, optional
    warn : callable(str), optional
        Told each warning line (e.g. a skill whose world is unknown) before serving.

    Returns
    -------
    ServeResult
    """
    from hlcmp_drake.config.loading import load_scenario

    scenario, _ = load_scenario(
        name_or_path,
        overrides,
        experiment_worlds(),
        replay_problem=replayed_reference_problem(None, skill, skill_path),
    )
    warnings: list[str] = []
    scenario, controller, theta0 = served_scenario(
        scenario, controller, skill, freeze, skill_path, any_scenario, warnings.append
    )
    check_served_priority(scenario.iiwa_driver, lcm_url)
    for warning in warnings:
        if warn is not None:
            warn(warning)
    lcm = open_lcm(lcm_url)
    setup = (
        prepare(scenario, skill.dmp, skill.orientation) if skill is not None else prepare(scenario)
    )
    client = TorqueClient(scenario, controller, lcm, theta0, setup)
    if lcm_url.startswith("memq://"):
        reporter.say(f"serve: {controller} and the simulated driver in this process (memq://)")
        lockstep(SimulatedIiwaDriver(scenario, lcm, setup), client, lcm)
    else:
        with realtime_scheduling(served_priority(scenario.iiwa_driver, lcm_url)):
            serve(client, lcm, lcm_url, reporter)
    served = {
        "skill": None if skill_path is None else str(Path(skill_path).resolve()),
        "adaptation": "frozen" if freeze else "on" if client.law.learns else "none",
        "overrides": [str(override) for override in overrides],
    }
    return write_served(client, out_dir, lcm_url, served)
