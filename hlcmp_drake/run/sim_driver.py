"""`hlcmp sim-driver`: a scenario's simulated iiwa and world behind the iiwa driver's LCM
protocol, behaving like drake-iiwa-driver in torque-only mode on a real arm:

- every period it publishes lcmt_iiwa_status (measured q, estimated v, the commanded,
  measured and external joint torques) and the wrist sensor's lcmt_force_torque (the
  force and the torque about the tool point);
- it applies each command's torques on top of its own gravity compensation G(q);
- it aborts on a command that comes within 0.25 s of its first status (a controller
  left running from before), and holds the arm with joint PD (the real driver's gains)
  while no fresh command has come for 50 ms.

Two pacings: as fast as the client answers (default: each status waits for the command
that answers it, so no tick is ever missed and the run is deterministic), or real time
(a period of wall-clock time per step; the latest command is applied, as on the robot).
Simulated time stands still at 0, the arm held, until the first command.

The simulation is stepped from Python, one plant step at a time and a period per command,
with the command (plus gravity compensation) fixed on the plant's actuation input: no LCM
systems inside the diagram, so an LCM event never splits a plant step. A command acts from
its status on, or `command_delay_steps` plant steps later (1: Drake's simulated driver).
"""

from __future__ import annotations

import dataclasses as dc
import math
import time
from typing import Sequence

import numpy as np
from pydrake.lcm import DrakeLcm
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.systems.analysis import SimulatorStatus

from hlcmp_drake.config.scenario import Scenario
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.iiwa_lcm import (
    IiwaStatus,
    ProtocolError,
    decode_torque_command,
    encode_status,
    encode_wrench,
    open_lcm,
)
from hlcmp_drake.present.progress import SILENT, Progress
from hlcmp_drake.run.interrupts import StopSignals
from hlcmp_drake.run.simulate import prepared_simulator
from hlcmp_drake.worlds.arm import ArmSetup
from hlcmp_drake.worlds.build import driven_world_of
from hlcmp_drake.worlds.models import scoped_frame

# drake-iiwa-driver's torque-only constants: its start-command guard, the age at which a
# command expires, and the joint PD gains of its holding controller.
START_COMMAND_GUARD_S = 0.25
COMMAND_EXPIRE_S = 0.05
HOLD_KP = np.array([1000.0, 1000.0, 1000.0, 500.0, 500.0, 500.0, 500.0])
HOLD_KD = np.array([50.0, 50.0, 50.0, 50.0, 35.0, 35.0, 35.0])
# As-fast pacing: a status not answered within this long is published again (a lost datagram).
RESEND_S = 0.02


class DriverAbort(Exception):
    """The simulated driver stops, as the real one would: a command within its start
    guard, a malformed command, or a simulation that failed."""


@dc.dataclass
class DriverSummary:
    """How a `drive` ended: steps simulated (those a command acted in, those the driver
    held the arm in; in real time, the steps that started more than a period late), the
    simulated and wall time, and why it stopped. A step of neither kind had its command
    still waiting out `command_delay_s`, the arm under gravity compensation and the torque
    in force before it (none, or the hold's)."""

    steps: int
    commanded_steps: int
    held_steps: int
    late_steps: int
    sim_time_s: float
    wall_s: float
    stopped_because: str
    command_delay_s: float = 0.0
    interrupted: bool = False  # by Ctrl-C or SIGTERM: `stopped_because` says which and when


class SimulatedIiwaDriver:
    """The scenario's world with its iiwa driven through LCM messages.

    Parameters
    ----------
    scenario : Scenario
        An arm scenario; its `iiwa_driver` names the channels and the period (a whole
        number of plant steps).
    lcm : DrakeLcm
        Where to publish and subscribe.
    setup : ArmSetup, optional
        The start posture (default: `prepare(scenario)`, as a run would start).
    command_delay_steps : int
        Plant steps between a status and the first step its command acts on: 0 (default)
        acts from the status on, as the simulated run's controller does; 1 is Drake's
        simulated iiwa driver, whose LCM subscriber takes a command in after the plant
        step that has already begun (`run.drake_driver`).

    Raises
    ------
    InputError
        For a scenario that is not an arm's, a period that is not a whole number of
        plant steps, or a negative delay.
    """

    def __init__(
        self,
        scenario: Scenario,
        lcm: DrakeLcm,
        setup: ArmSetup | None = None,
        *,
        command_delay_steps: int = 0,
    ):
        world = driven_world_of(scenario, "the simulated iiwa driver drives an arm")
        self.config = scenario.iiwa_driver
        step = scenario.plant_config.time_step
        self.period = self.config.period_s
        steps_per_period = plant_steps_per_period(scenario)
        if command_delay_steps < 0:
            raise InputError(f"--command-delay {command_delay_steps}: expected 0 or more steps")
        self.command_delay_steps = command_delay_steps
        self._plant_step = step
        self._steps_per_period = steps_per_period
        self._lcm = lcm
        setup = setup or world.prepare(scenario, None)
        assert world.build_driven is not None
        built = world.build_driven(scenario, setup)
        self.plant = built.plant
        self.simulator = prepared_simulator(built, scenario)
        status = self.simulator.Initialize()
        if status.reason() == SimulatorStatus.ReturnReason.kReachedTerminationCondition:
            raise DriverAbort(f"the world stopped at t = 0: {status.message()}")
        root = self.simulator.get_mutable_context()
        self._context = self.plant.GetMyMutableContextFromRoot(root)
        sensor = built.diagram.GetSubsystemByName("wrist_force_sensor")
        self._force = sensor.GetOutputPort("force")
        self._torque = sensor.GetOutputPort("torque")
        self._sensor_context = sensor.GetMyContextFromRoot(root)
        self._tool = scoped_frame(self.plant, scenario.task.tool_frame)
        self._actuation = self.plant.get_actuation_input_port()
        self._limits = np.array(
            [
                self.plant.get_joint_actuator(i).effort_limit()
                for i in self.plant.GetJointActuatorIndices()
            ]
        )
        self.nv = self.plant.num_velocities()
        self._applied = np.zeros(self.nv)  # the torque in force (a command's or the hold's)
        self._commanding = False  # whether _applied is a command's
        self._pending: list[tuple[int, np.ndarray]] = []  # (the plant step it acts from, torque)
        self._hold = None
        self._plant_steps = 0
        self.command: tuple[int, np.ndarray, float] | None = (
            None  # utime, torque, wall time received
        )
        self._first_status_wall = None
        self.status_utime = 0
        lcm.Subscribe(self.config.command_channel, self._on_command)

    @property
    def time(self) -> float:
        """The simulated time [s]."""
        return self._context.get_time()

    @property
    def command_delay_s(self) -> float:
        """`command_delay_steps` in simulated time [s]."""
        return self.command_delay_steps * self._plant_step

    def publish_status(self) -> None:
        """Publish the wrist sensor's wrench and the arm's status at the present time."""
        plant, context = self.plant, self._context
        q, v = plant.GetPositions(context), plant.GetVelocities(context)
        force_world = self._force.Eval(self._sensor_context)
        torque_tool = self._torque.Eval(self._sensor_context)
        rotation = self._tool.CalcRotationMatrixInWorld(context)
        jacobian = plant.CalcJacobianSpatialVelocity(
            context,
            JacobianWrtVariable.kV,
            self._tool,
            np.zeros(3),
            plant.world_frame(),
            plant.world_frame(),
        )
        self.status_utime = int(round(self.time * 1e6))
        # As Drake's simulated iiwa reports them: the joint torque (the command in force
        # plus gravity compensation at this state, saturated) negated, for both the
        # commanded and the measured torque; the wrist sensor's wrench (its torque about
        # the tool point) is the arm's external torque J^T [τ; f], with its own sign.
        joint_torque = -self._joint_torque(self._applied)
        wrench_world = np.concatenate([rotation @ torque_tool, force_world])
        status = IiwaStatus(
            self.status_utime, q, v, joint_torque, joint_torque, jacobian.T @ wrench_world
        )
        self._lcm.Publish(
            self.config.wrist_channel,
            encode_wrench(self.status_utime, rotation.inverse() @ force_world, torque_tool),
        )
        self._lcm.Publish(self.config.status_channel, encode_status(status))
        if self._first_status_wall is None:
            self._first_status_wall = time.perf_counter()

    def _on_command(self, data: bytes) -> None:
        now = time.perf_counter()
        try:
            utime, torque = decode_torque_command(data, self.nv)
        except ProtocolError as error:
            raise DriverAbort(f"the driver received {error}") from None
        if self._first_status_wall is None or now - self._first_status_wall < START_COMMAND_GUARD_S:
            raise DriverAbort(
                f"a command came within {START_COMMAND_GUARD_S} s of the driver's first status "
                "(a controller left running from before?); the real driver aborts too"
            )
        self.command = (utime, torque, now)

    def _joint_torque(self, torque: np.ndarray) -> np.ndarray:
        """What the joints get for a command's `torque`: it plus gravity compensation
        G(q) at the present state, saturated at the effort limits [N m]."""
        gravity = -self.plant.CalcGravityGeneralizedForces(self._context)
        return np.clip(torque + gravity, -self._limits, self._limits)

    def step(self, torque: np.ndarray | None) -> bool:
        """Advance one period with `torque` on top of gravity compensation (recomputed
        every plant step), from `command_delay_steps` plant steps on, or (None) hold the
        arm where it is with the driver's joint PD.

        Parameters
        ----------
        torque : (nv,) array or None
            The command's joint torques [N m].

        Returns
        -------
        bool
            Whether a command's torques acted in a plant step of this period (not while
            every command was still waiting out the delay, nor while holding).

        Raises
        ------
        DriverAbort
            When the simulation fails or the arm's state is no longer finite.
        """
        plant, context = self.plant, self._context
        q, v = plant.GetPositions(context), plant.GetVelocities(context)
        if torque is None:
            self._hold = q.copy() if self._hold is None else self._hold
            self._pending.clear()
            self._applied = -HOLD_KP * (q - self._hold) - HOLD_KD * v
            self._commanding = False
        else:
            self._hold = None
            self._pending.append(
                (self._plant_steps + self.command_delay_steps, np.asarray(torque, dtype=float))
            )
        acted = False
        for _ in range(self._steps_per_period):
            while self._pending and self._pending[0][0] <= self._plant_steps:
                self._applied = self._pending.pop(0)[1]
                self._commanding = True
            acted = acted or self._commanding
            self._actuation.FixValue(context, self._joint_torque(self._applied))
            # To a whole number of plant steps, as Drake times them: t + step could land a
            # rounding error past a step and take it too.
            self._plant_steps += 1
            try:
                status = self.simulator.AdvanceTo(self._plant_steps * self._plant_step)
            except RuntimeError as error:
                message = " ".join(str(error).split())[:200]
                raise DriverAbort(
                    f"the simulation failed at t = {self.time:.3f} s: {message}"
                ) from None
            if status.reason() == SimulatorStatus.ReturnReason.kReachedTerminationCondition:
                raise DriverAbort(f"the world stopped at t = {self.time:.3f} s: {status.message()}")
        if not np.all(np.isfinite(plant.GetPositionsAndVelocities(context))):
            raise DriverAbort(f"the simulated arm's state is not finite at t = {self.time:.3f} s")
        return acted


def plant_steps_per_period(scenario: Scenario) -> int:
    """The plant steps in one of the driver's periods (`iiwa_driver.period_s`).

    Parameters
    ----------
    scenario : Scenario

    Returns
    -------
    int

    Raises
    ------
    InputError
        For a period that is not a whole number of plant steps.
    """
    step, period = scenario.plant_config.time_step, scenario.iiwa_driver.period_s
    if step <= 0 or abs(period / step - round(period / step)) > 1e-9:
        raise InputError(
            f"{scenario.name}: iiwa_driver.period_s = {period} s must be a whole number "
            f"of plant steps (plant_config.time_step = {step} s)"
        )
    return int(round(period / step))


def _reached(time_s: float, duration: float, period: float) -> bool:
    """Whether `drive` stops at `time_s` for `duration`: at the whole period nearest it."""
    return time_s >= duration - period / 2


def periods_to(duration: float, period: float, steps_per_period: int, plant_step: float) -> int:
    """The periods `drive` simulates to `duration` (the whole number nearest it), counted as
    it counts them, the simulated time a whole number of plant steps.

    Parameters
    ----------
    duration : float
        --duration [s].
    period : float
        The driver's period [s].
    steps_per_period : int
        Plant steps in a period.
    plant_step : float
        The plant's step [s].

    Returns
    -------
    int
    """

    def time_after(periods: int) -> float:
        return periods * steps_per_period * plant_step

    periods = max(0, math.ceil((duration - period / 2) / period))
    while periods > 0 and _reached(time_after(periods - 1), duration, period):
        periods -= 1
    while not _reached(time_after(periods), duration, period):
        periods += 1
    return periods


def wait_for_first_command(
    driver: SimulatedIiwaDriver, lcm: DrakeLcm, timeout_s: float, stop: StopSignals | None = None
) -> None:
    """Publish the t = 0 status every period (the arm held still, time standing) until a
    first command comes (or Ctrl-C or SIGTERM).

    Parameters
    ----------
    driver : SimulatedIiwaDriver
    lcm : DrakeLcm
    timeout_s : float
        Give up after this long [s].
    stop : StopSignals, optional
        Stop waiting when it received one (`driver.command` then still None).

    Raises
    ------
    DriverAbort
        When no command came within `timeout_s`.
    """
    start = time.perf_counter()
    while driver.command is None and not (stop is not None and stop.received):
        driver.publish_status()
        # Sleep in LCM's own wait (whole ms) rather than poll to the µs: time stands
        # still, so nothing needs the period kept, and a driver left waiting for a client
        # (up to a minute) keeps no core busy.
        lcm.HandleSubscriptions(max(1, round(driver.period * 1000)))
        if time.perf_counter() - start > timeout_s:
            raise DriverAbort(
                f"no command on {driver.config.command_channel} within {timeout_s:g} s"
            )


def drive(
    driver: SimulatedIiwaDriver,
    lcm: DrakeLcm,
    realtime: bool = False,
    duration: float | None = None,
    idle_timeout_s: float = 1.0,
    first_command_timeout_s: float = 60.0,
    reporter: Progress = SILENT,
) -> DriverSummary:
    """Run the simulated driver until its client stops commanding (or `duration`, or
    Ctrl-C or SIGTERM: then between two steps, the summary `interrupted`).

    Parameters
    ----------
    driver : SimulatedIiwaDriver
    lcm : DrakeLcm
        The one the driver subscribed on.
    realtime : bool
        Pace one period of wall-clock time per step (the latest command applied; held
        after 50 ms without one); False: each status waits for the command that answers it.
    duration : float, optional
        Stop at this simulated time [s] (default: when the client stops).
    idle_timeout_s : float
        The client counts as gone after this long without a command [s].
    first_command_timeout_s : float
        How long to wait for the first command [s].
    reporter : Progress, optional

    Returns
    -------
    DriverSummary

    Raises
    ------
    DriverAbort
        When the driver aborts (see `SimulatedIiwaDriver`).
    """
    reporter.say(
        f"sim-driver: publishing {driver.config.status_channel} every "
        f"{driver.period * 1000:.0f} ms "
        f"({'real time' if realtime else 'as fast as the client answers'}); waiting for a command"
    )
    with StopSignals() as stop:
        wait_for_first_command(driver, lcm, first_command_timeout_s, stop)
        start = time.perf_counter()
        steps, commanded, held, late, stopped = (
            _drive(driver, lcm, realtime, duration, idle_timeout_s, stop)
            if driver.command is not None
            else (0, 0, 0, 0, None)
        )
    interrupted = stopped is None
    if stopped is None:
        stopped = stop.stopped_at(driver.time, driver.command is not None)
    return DriverSummary(
        steps,
        commanded,
        held,
        late,
        driver.time,
        time.perf_counter() - start,
        stopped,
        driver.command_delay_s,
        interrupted,
    )


def _drive(
    driver: SimulatedIiwaDriver,
    lcm: DrakeLcm,
    realtime: bool,
    duration: float | None,
    idle_timeout_s: float,
    stop: StopSignals,
) -> tuple[int, int, int, int, str | None]:
    """`drive`'s loop from the first command on: (steps, commanded, held, late, why it
    stopped), the reason None where Ctrl-C or SIGTERM stopped it (between two steps)."""
    steps = commanded = held = late = 0
    stopped = None
    deadline = time.perf_counter()
    while stopped is None:
        if stop.received:
            break
        if duration is not None and _reached(driver.time, duration, driver.period):
            stopped = f"reached --duration {duration:g} s"
            break
        if realtime:
            deadline += driver.period
            if (
                time.perf_counter() > deadline + driver.period
            ):  # a step overran: keep pace, don't burst
                late += 1
                deadline = time.perf_counter()
            _handle_until(lcm, deadline)
            age = time.perf_counter() - driver.command[2]
            fresh = age <= COMMAND_EXPIRE_S
            commanded += driver.step(driver.command[1] if fresh else None)
            held += not fresh
            steps += 1
            if age > idle_timeout_s:
                stopped = f"no command for {idle_timeout_s:g} s (the client stopped)"
        else:
            stopped = _await_answer(driver, lcm, idle_timeout_s, stop)
            if stopped is None and stop.received:
                continue  # the status unanswered: stopped at the loop's top
            if stopped is None:
                commanded += driver.step(driver.command[1])
                steps += 1
        if stopped is None:
            driver.publish_status()
    return steps, commanded, held, late, stopped


def check_command_delay(scenario: Scenario, duration: float, command_delay_steps: int) -> None:
    """Refuse a delay under which no command would act before `duration` ends: as many
    plant steps as the run takes (to the whole period nearest `duration`, as `drive`
    stops) or more, counted from the first command (whose status is at t = 0).

    Parameters
    ----------
    scenario : Scenario
        Its plant step and the driver's period.
    duration : float
        --duration [s], simulated time from the first command.
    command_delay_steps : int
        --command-delay.

    Raises
    ------
    InputError
        Naming --command-delay and the run's length.
    """
    step, period = scenario.plant_config.time_step, scenario.iiwa_driver.period_s
    steps_per_period = plant_steps_per_period(scenario)
    run_steps = periods_to(duration, period, steps_per_period, step) * steps_per_period
    if command_delay_steps >= run_steps:  # the first command would act after the end
        run_s = run_steps * step
        rounded = "" if math.isclose(run_s, duration) else f" {duration:g} s to whole periods"
        raise InputError(
            f"--command-delay {command_delay_steps}: {command_delay_steps * step:g} s of plant "
            f"steps must be shorter than the run ({run_s:g} s, --duration{rounded})"
        )


def _await_answer(
    driver: SimulatedIiwaDriver, lcm: DrakeLcm, idle_timeout_s: float, stop: StopSignals
) -> str | None:
    """Wait for the command answering the last status (publishing it again every RESEND_S);
    None when it came or a signal asked to stop, else why the client counts as gone. It polls
    without sleeping: a simulator paced by its client has a core to itself, and the
    client's tick measured faster with the other core kept busy (scripts/serve_latency.py)."""
    since = sent = time.perf_counter()
    while driver.command[0] != driver.status_utime and not stop.received:
        lcm.HandleSubscriptions(0)
        now = time.perf_counter()
        if now - since > idle_timeout_s:
            return (
                f"the client stopped answering at t = {driver.time:.3f} s "
                f"(no command for {idle_timeout_s:g} s)"
            )
        if now - sent > RESEND_S:
            driver.publish_status()
            sent = now
    return None


def _handle_until(lcm: DrakeLcm, deadline: float) -> None:
    """Handle LCM messages until the wall-clock `deadline` (perf_counter seconds)."""
    while True:
        remaining = deadline - time.perf_counter()
        if remaining <= 0:
            return
        # HandleSubscriptions waits in whole milliseconds: sleep in it while more than
        # 2 ms remain, then poll, so the deadline is kept to well under a period.
        lcm.HandleSubscriptions(int(remaining * 1000) - 1 if remaining > 0.002 else 0)


def run_sim_driver(
    name_or_path: str,
    lcm_url: str,
    realtime: bool = False,
    duration: float | None = None,
    idle_timeout_s: float = 1.0,
    overrides: Sequence[str] = (),
    reporter: Progress = SILENT,
    *,
    command_delay_steps: int = 0,
) -> DriverSummary:
    """Load a scenario and run its simulated iiwa driver on `lcm_url` until the client stops.

    Parameters
    ----------
    name_or_path : str
        A bundled arm scenario or a YAML file.
    lcm_url : str
        E.g. udpm://239.255.76.67:7667?ttl=0.
    realtime, duration, idle_timeout_s, reporter
        As for `drive`.
    overrides : sequence of str
        ``dotted.key=value`` overrides of the scenario.
    command_delay_steps : int
        As for `SimulatedIiwaDriver` (1: Drake's simulated driver's timing); fewer plant
        steps than the run simulates when `duration` is given (`check_command_delay`).
        Without it the driver runs until the client stops, for no length known here (the
        scenario's `duration_s` is not it), so there is nothing to check the delay
        against: the summary's commanded steps count only those a command acted in.

    Returns
    -------
    DriverSummary

    Raises
    ------
    InputError
        For a bad scenario, URL or delay, before the world is built.
    """
    from hlcmp_drake.config.loading import load_scenario

    if lcm_url.startswith("memq://"):
        raise InputError(
            "--lcm memq:// reaches only this process: hlcmp serve SCENARIO --lcm memq:// "
            "runs the simulated driver and the client together"
        )
    scenario, _ = load_scenario(name_or_path, overrides)
    if duration is not None and command_delay_steps:
        check_command_delay(scenario, duration, command_delay_steps)
    lcm = open_lcm(lcm_url)
    driver = SimulatedIiwaDriver(scenario, lcm, command_delay_steps=command_delay_steps)
    return drive(driver, lcm, realtime, duration, idle_timeout_s, reporter=reporter)
