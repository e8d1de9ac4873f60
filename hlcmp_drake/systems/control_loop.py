"""A world's controller in one Python evaluation per plant step: the fast path (the arm's
and the slider's).

The modular systems (TaskSpaceDynamics -> controller -> NullSpaceImpedance ->
TaskForceToJointTorque) are evaluated by Drake port by port and at every integrator
stage: about 35 Python calls per 1 ms plant step. `ControlLoop` does the same work
once per step, as a real 1 kHz torque loop does, with the same functions:

    plant state (sampled at t_k) --TaskSpaceModel--> x, x', J, Λ, C_x, G_x, N^T, G(q)
    + reference (x_d, x_d', x_d'', s at t_k) + θ(t_k)  --law.command--> f_c, θ'
    τ_k = sat(J^T f_c + BelowTaskImpedance)            (held over [t_k, t_k+1))
    θ' held over the step; a C++ Integrator holds θ as continuous state.

θ is the law's integrated state: a learner's weights, the variable impedance's commanded
motion and Φ. The slider world runs the same loop with its own task model and no torque
below the task.

It runs as a periodic unrestricted update at the plant's period, which Drake handles
before the plant's own discrete update at the same time, so the plant steps with τ_k
computed from its state at t_k, as with the modular systems.

θ scheme: the rate is sampled once per step, from the plant state, θ and reference at
t_k, and held; Drake integrates the held rate exactly, so θ_{k+1} = θ_k + h θ'(t_k): the
explicit-Euler step of Table I ("for each time step: compute the increment rates (Eq.
31), update these parameters"), first order in h. The modular path instead evaluates Eq.
31 at both RK2 stages with the plant state after the step; the two differ by O(h) in θ
(measured in tests/test_worlds_arm.py and docs/performance.md).
"""

from __future__ import annotations

import dataclasses as dc
import time
from collections.abc import Callable
from functools import cached_property

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, State, ValueProducer

from hlcmp_drake.core.kernels import implementation, kernel_path
from hlcmp_drake.core.laws import ControlLaw, LawOutput, TaskSpaceInstant
from hlcmp_drake.core.operational_space import task_joint_torque
from hlcmp_drake.systems.arm import BelowTaskImpedance
from hlcmp_drake.systems.ports import REFERENCE_PORTS
from hlcmp_drake.systems.task_space import PrismaticTaskModel, TaskSpaceModel


@dc.dataclass
class TickResult:
    """One tick: the task-space terms it read, the law's output, and the joint torque.

    Attributes
    ----------
    terms : TaskSpaceTerms
        At the tick's plant state (`TaskSpaceModel.terms`); `terms.joint_gravity` is G(q).
    law : LawOutput
        f_c [N], the logged series and (learning) θ's rate.
    torque : (nv,) array
        The saturated joint torque [N m], gravity compensation G(q) included.
    saturated : int
        The number of joints at their effort limit.
    """

    terms: object
    law: LawOutput
    torque: np.ndarray
    saturated: int

    @property
    def joint_gravity(self) -> np.ndarray:
        """G(q) at the tick's state [N m] (`terms.joint_gravity`): what a driver that
        compensates gravity itself takes off the torque."""
        return self.terms.joint_gravity  # type: ignore[attr-defined]


class DeferredTermsResult(TickResult):
    """`TickResult` whose `terms` are formed when first read, as `terms_of(*arguments)`: a
    torque loop reads only the torque and θ', the loggers read the terms at 100 Hz.

    Parameters
    ----------
    terms_of : callable
        Returns the tick's `TaskSpaceTerms` from `arguments`.
    arguments : tuple
        What the tick computed on the way.
    law, torque, saturated
        As for `TickResult`.
    joint_gravity : (nv,) array, optional
        G(q), where the tick has it: read without forming the terms (a served tick reads
        it every status).
    """

    def __init__(
        self,
        terms_of: Callable,
        arguments: tuple,
        law: LawOutput,
        torque: np.ndarray,
        saturated: int,
        joint_gravity: np.ndarray | None = None,
    ):
        self._terms_of, self._arguments = terms_of, arguments
        self.law, self.torque, self.saturated = law, torque, saturated
        self._joint_gravity = joint_gravity

    @property
    def joint_gravity(self) -> np.ndarray:
        """G(q) at the tick's state [N m]."""
        if self._joint_gravity is None:
            return self.terms.joint_gravity  # type: ignore[attr-defined]
        return self._joint_gravity

    @cached_property
    def terms(self) -> object:  # type: ignore[override]
        """The task-space terms at the tick's plant state."""
        return self._terms_of(*self._arguments)


class ControlTick:
    """A world's whole controller at one instant: the task-space terms, the law, the
    torque below the task and the saturation. `ControlLoop` calls it once per plant
    step; `hlcmp serve` calls it once per status of the iiwa driver.

        plant state --TaskSpaceModel--> x, x', J, Λ, C_x, G_x, N^T, G(q)
        + reference (x_d, x_d', x_d'', s) + θ  --law.command--> f_c, θ'
        τ = sat(J^T f_c + BelowTaskImpedance)

    Between the plant queries, the arithmetic is `core`'s functions, compiled by numba or
    plain numpy (`kernel`, from `core.kernels.kernel_path` when the tick is made; the
    model, the law and the torque below the task choose theirs the same way when they are
    made).

    Parameters
    ----------
    model : TaskSpaceModel or PrismaticTaskModel
        The task point's task-space terms.
    below_task : BelowTaskImpedance or None
        The arm's orientation and posture held below the task, of the model's frame (it
        reads that frame's orientation and J_w from the model's terms); None where the
        task axes are all the joints (the slider).
    law : ControlLaw
        The task-space law (`core.laws`).
    effort_limits : (nv,) array
        The actuators' effort limits [N m].

    Attributes
    ----------
    kernel : str
        ``compiled`` or ``numpy``: the path of the tick's arithmetic.
    reference_ports : tuple of (str, int)
        The reference inputs `evaluate` takes, in order: name and size.
    n_axes : int
        M, the task axes (the size of f_c and of a read external force).
    extra_series : dict of str to str
        Further loggable values of `log_row` -> their series name (none here).

    Raises
    ------
    ValueError
        When `below_task` holds another frame than the model's.
    """

    extra_series: dict[str, str] = {}

    def __init__(
        self,
        model: TaskSpaceModel | PrismaticTaskModel,
        below_task: BelowTaskImpedance | None,
        law,
        effort_limits,
    ):
        if below_task is not None and below_task.frame.index() != model.frame.index():
            raise ValueError(
                f"the torque below the task holds {below_task.frame.name()!r}, the task "
                f"model's frame is {model.frame.name()!r}: the tick reads the orientation "
                "and J_w from the model's terms, so they must be one frame"
            )
        self.model, self.below_task, self.law = model, below_task, law
        self.effort_limits = np.asarray(effort_limits, dtype=float)
        self.kernel = kernel_path()
        self._task_joint_torque = implementation(task_joint_torque, self.kernel)
        self._nothing_below = np.zeros(model.nv)
        m = self.n_axes = model.n_axes
        self.reference_ports = tuple(
            (name, 1 if name == "phase" else m) for name in REFERENCE_PORTS
        )
        self.log_columns = {
            "position": slice(0, m),
            "force": slice(m, 2 * m),
            "saturated": slice(2 * m, 2 * m + 1),
        }
        for k, name in enumerate(law.log_fields):
            self.log_columns[name] = slice(2 * m + 1 + k * m, 2 * m + 1 + (k + 1) * m)
        self.log_size = 2 * m + 1 + m * len(law.log_fields)

    def evaluate(
        self,
        state: np.ndarray,
        reference: tuple,
        theta: np.ndarray | None,
        *,
        time: float = 0.0,
        external_force: np.ndarray | None = None,
    ) -> TickResult:
        """The controller's output at one plant state.

        Parameters
        ----------
        state : (nq + nv,) array
            The plant's positions [rad] and velocities [rad/s].
        reference : tuple of (M,), (M,), (M,), (1,) arrays
            x_d [m], x_d' [m/s], x_d'' [m/s^2] and the phase s.
        theta : (P,) array or None
            The law's integrated state (a learner's flattened weights); None for a law
            without one.
        time : float
            The instant [s], for a law with a schedule (the variable impedance's f_d(t)).
        external_force : (M,) array, optional
            The measured environment force [N], for a law that reads it.

        Returns
        -------
        TickResult
        """
        terms = self.model.terms(state, coriolis_matrix=False)
        xd, xd_dot, xd_ddot, phase = reference
        now = TaskSpaceInstant(
            terms.position,
            terms.velocity,
            xd,
            xd_dot,
            xd_ddot,
            phase[0],
            terms.inertia,
            terms.coriolis,
            terms.gravity,
            time,
            external_force,
        )
        out = self.law.command(now, theta)
        below = (
            self._nothing_below
            if self.below_task is None
            else self.below_task.torque_at(
                state,
                terms.null_space,
                terms.joint_gravity,
                terms.rotation,
                terms.angular_jacobian,
            )
        )
        torque, saturated = self._task_joint_torque(
            terms.jacobian, out.force, below, self.effort_limits
        )
        return TickResult(terms, out, torque, saturated)

    def held_command(
        self,
        state: np.ndarray,
        reference: tuple,
        theta: np.ndarray | None,
        time: float = 0.0,
        external_force: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """What `ControlLoop` holds until the next tick: `evaluate`'s torque and θ' alone
        (a fused tick forms them without the rest of the result). Its arguments may be
        given by position, as `ControlLoop` gives them every tick.

        Parameters
        ----------
        state, reference, theta, time, external_force
            As for `evaluate`.

        Returns
        -------
        torque : (nv,) array
            The saturated joint torque [N m].
        rates : (P,) array or None
            θ', None for a law without θ.
        """
        return self._torque_and_rates(state, reference, theta, time, external_force)

    def _torque_and_rates(self, state, reference, theta, time, external_force):
        """`held_command`'s work: from `evaluate` here; a fused tick slices its kernel's
        output instead."""
        result = self.evaluate(state, reference, theta, time=time, external_force=external_force)
        return result.torque, result.law.rates

    def log_row(self, result: TickResult) -> np.ndarray:
        """The tick's loggable values in the layout of `log_columns`: x, f_c, the number of
        saturated joints and the law's logged series.

        Parameters
        ----------
        result : TickResult
            From `evaluate`.

        Returns
        -------
        (log_size,) array
        """
        return np.concatenate(
            [
                result.terms.position,
                result.law.force,
                [result.saturated],
                *(result.law.logs[name] for name in self.law.log_fields),
            ]
        )


class ControlLoop(LeafSystem):
    """`ControlTick` as a Drake system, evaluated once per plant step.

    Sizes: M task-space axes (the model's), nq positions and nv velocities of the plant,
    P = `law.theta_size` (3 M N for the Hl-CMP, N basis functions; 3 M for the variable
    impedance; 0 for the constant impedance).

    Input ports:

    - ``plant_state`` (nq + nv): the plant's positions q [rad] and velocities v [rad/s].
    - ``desired_position``, ``desired_velocity``, ``desired_acceleration`` (M): x_d [m],
      x_d' [m/s], x_d'' [m/s^2] from the reference.
    - ``phase`` (1): the canonical phase s [-].
    - the 6-D tick's (`systems.pose_control.PoseControlTick`) also
      ``desired_orientation`` (4), ``desired_angular_velocity`` (3) and
      ``desired_angular_acceleration`` (3): R_d (w, x, y, z), ω_d [rad/s], ω_d' [rad/s^2],
      world (the tick's `reference_ports` list them).
    - ``theta`` (P), only for a law with a state (P > 0): a learner's flattened weights
      θ = [θ_k, θ_d, θ_v] (each (M, N) row-major; for the Hl-CMP [N/m], [N s/m], [N]), the
      variable impedance's [x_c, x_c', Φ]; from an Integrator.
    - ``external_force`` (M), only for a law that reads it (the variable impedance): the
      measured reaction force of the environment [N].

    Output ports:

    - ``joint_torque`` (nv): the saturated joint torque of the last tick, held until the
      next [N m], gravity compensation G(q) included; zero before the first tick.
    - ``theta_rate`` (P), only for a law with a state: θ' of the last tick, held (the
      Integrator's input) [θ's units per s].
    - ``logs`` (`ControlTick.log_size` = 2 M + 1 + M K, K the law's `log_fields`): the
      loggable series evaluated at the present context, not held: x [m], f_c [N], the
      number of saturated joints [-], then each logged series (M), then the tick's
      `extra_series` (the 6-D tick's commanded torque and tool orientation); layout in
      `log_columns`.

    Parameters
    ----------
    tick : ControlTick
        The controller.
    period : float
        The plant's time step [s]: one tick per step.
    """

    def __init__(self, tick: ControlTick, period: float):
        super().__init__()
        self._tick_of = tick
        law, model = tick.law, tick.model
        nq, nv = model.nq, model.nv
        self.plant_state = self.DeclareVectorInputPort("plant_state", BasicVector(nq + nv))
        self._reference = [
            self.DeclareVectorInputPort(name, BasicVector(size))
            for name, size in tick.reference_ports
        ]
        self.theta = (
            self.DeclareVectorInputPort("theta", BasicVector(law.theta_size))
            if law.theta_size
            else None
        )
        self.external_force = (
            self.DeclareVectorInputPort("external_force", BasicVector(tick.n_axes))
            if law.reads_external_force
            else None
        )
        self._torque_index = self.DeclareDiscreteState(nv)
        self.DeclareStateOutputPort("joint_torque", self._torque_index)
        if law.theta_size:
            self._rate_index = self.DeclareDiscreteState(law.theta_size)
            self.DeclareStateOutputPort("theta_rate", self._rate_index)
        self.DeclarePeriodicUnrestrictedUpdateEvent(period, 0.0, self._tick)
        self.log_columns = tick.log_columns
        # The tick's whole result at the present inputs and time, for the logs; a tick at
        # an instant whose logs were read (every logger's sample) takes its torque and θ'
        # from it rather than computing them again.
        self._result = self.DeclareCacheEntry(
            "result",
            ValueProducer(allocate=lambda: AbstractValue.Make(None), calc=self._calc_result),
            {self.all_input_ports_ticket(), self.time_ticket()},
        )
        self.DeclareVectorOutputPort(
            "logs",
            tick.log_size,
            lambda c, o: o.SetFromVector(tick.log_row(self._result.Eval(c))),
            {self._result.ticket()},
        )
        self.tick_seconds: list[float] | None = None

    @property
    def law(self) -> ControlLaw:
        """The `core.laws` law the loop evaluates (as `LawController.law`)."""
        return self._tick_of.law

    def record_tick_times(self) -> list[float]:
        """Start recording the wall time of every tick that computes its command (for the
        benchmark): a tick at an instant whose logs were read takes the result the loggers
        had computed, and is not recorded.

        Returns
        -------
        list of float
            Filled with one duration [s] per computing tick as the simulation runs.
        """
        self.tick_seconds = []
        return self.tick_seconds

    def _inputs(self, context) -> tuple:
        """The tick's arguments at `context`: state, reference, θ, time, measured force."""
        theta, force = self.theta, self.external_force
        return (
            self.plant_state.Eval(context),
            tuple([port.Eval(context) for port in self._reference]),
            None if theta is None else theta.Eval(context),
            context.get_time(),
            None if force is None else force.Eval(context),
        )

    def _tick(self, context: Context, state: State):
        start = time.perf_counter()
        computes = self._result.is_out_of_date(context)
        if computes:
            torque, rates = self._tick_of.held_command(*self._inputs(context))
        else:  # `held_command` would give the same numbers (tested to the bit)
            result = self._result.Eval(context)
            torque, rates = result.torque, result.law.rates
        state.get_mutable_discrete_state(self._torque_index).set_value(torque)
        if rates is not None:
            state.get_mutable_discrete_state(self._rate_index).set_value(rates)
        if self.tick_seconds is not None and computes:
            self.tick_seconds.append(time.perf_counter() - start)

    def _calc_result(self, context, abstract_value):
        state, reference, theta, now, force = self._inputs(context)
        abstract_value.set_value(
            self._tick_of.evaluate(state, reference, theta, time=now, external_force=force)
        )
