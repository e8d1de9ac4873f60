"""Desired-motion sources: the DMP (paper Eqs. 6-8, 13, 15) and a step reference.

Both have the same output ports -- desired_position, desired_velocity,
desired_acceleration (M each) and phase (1) -- so a controller cannot tell them apart.
The orientation DMP's source (`orientation_dmp_source`) adds the desired orientation, its
angular velocity and acceleration.
"""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Diagram,
    DiagramBuilder,
    LeafSystem,
    ValueProducer,
)
from pydrake.systems.primitives import AffineSystem, Demultiplexer, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from hlcmp_drake.core.dmp import Dmp, canonical_phase_rate, phase_at, transformation_matrices
from hlcmp_drake.core.orientation_dmp import (
    OrientationDmp,
    angular_acceleration,
    angular_velocity,
    orientation_from_error,
)

# The forcing term's samples for the spline that drives linear_dmp_source [s]. Measured
# error of the cubic: 4e-11 of f for the bundled DMPs (tau 8.5 s, N = 30); 7e-7 for tau 1 s,
# N = 50; 5e-6 for tau 1 s, N = 100 (narrower kernels).
FORCING_SAMPLE_S = 0.002


class DmpSource(LeafSystem):
    """A fitted DMP as a Drake system. Continuous state [p (M), z (M), s]; Drake integrates
    Eqs. 7, 8 and 15 through `Dmp.rates`. tau may differ from the demonstration's
    (temporal scaling); a new goal is set with `Dmp.with_goal` before construction.

    The state starts at p = `dmp.start` (p0) [m], z = 0, s = 1; z = tau p' is the scaled
    velocity [m].

    Input ports: none.

    Output ports (M task-space axes, the DMP's `n_axes`):

    - ``desired_position`` (M): x_d = p [m].
    - ``desired_velocity`` (M): x_d' = z / tau [m/s].
    - ``desired_acceleration`` (M): x_d'' = z' / tau [m/s^2] (Eq. 15, through `Dmp.rates`).
    - ``phase`` (1): the canonical phase s [-] (Eq. 8), from 1 decaying towards 0.

    Parameters
    ----------
    dmp : Dmp
        The fitted DMP (with a new goal already set, if any); its `n_axes` is M.
    tau : float, optional
        Time constant [s], > 0; default the demonstration's `dmp.tau` (another value:
        temporal scaling, the same path run faster or slower).
    """

    def __init__(self, dmp: Dmp, tau: float | None = None):
        super().__init__()
        self._dmp = dmp
        self._tau = dmp.tau if tau is None else float(tau)
        m = dmp.n_axes
        self._m = m
        initial = np.concatenate([dmp.start, np.zeros(m), [1.0]])
        self.DeclareContinuousState(BasicVector(initial), 0, 0, 2 * m + 1)
        state = {self.all_state_ticket()}
        # The derivatives and the acceleration output share one evaluation of the DMP.
        self._rates = self.DeclareCacheEntry(
            "dmp_rates",
            ValueProducer(allocate=lambda: AbstractValue.Make(None), calc=self._calc_rates),
            state,
        )
        self.DeclareVectorOutputPort("desired_position", m, self._calc_position, state)
        self.DeclareVectorOutputPort("desired_velocity", m, self._calc_velocity, state)
        self.DeclareVectorOutputPort(
            "desired_acceleration", m, self._calc_acceleration, {self._rates.ticket()}
        )
        self.DeclareVectorOutputPort("phase", 1, self._calc_phase, state)

    @property
    def tau(self) -> float:
        """The time constant tau [s] this source runs with."""
        return self._tau

    def _state(self, context):
        x = context.get_continuous_state_vector().CopyToVector()
        return x[: self._m], x[self._m : 2 * self._m], x[2 * self._m]

    def _calc_rates(self, context, abstract_value):
        abstract_value.set_value(self._dmp.rates(*self._state(context), self._tau))

    def DoCalcTimeDerivatives(self, context, derivatives):
        pdot, zdot, sdot = self._rates.Eval(context)
        derivatives.get_mutable_vector().SetFromVector(np.concatenate([pdot, zdot, [sdot]]))

    def _calc_position(self, context, output):
        output.SetFromVector(self._state(context)[0])

    def _calc_velocity(self, context, output):
        output.SetFromVector(self._state(context)[1] / self._tau)

    def _calc_acceleration(self, context, output):
        output.SetFromVector(self._rates.Eval(context)[1] / self._tau)

    def _calc_phase(self, context, output):
        output.SetFromVector([self._state(context)[2]])


def linear_dmp_source(dmp: Dmp, duration: float, tau: float | None = None) -> Diagram:
    """The DMP as Drake's own C++ systems, with the ports of `DmpSource`.

    The phase has a closed form (Eq. 8), so the forcing term f(s(t)) is a known function
    of time: a cubic spline of it drives an AffineSystem whose continuous state
    [p (M), z (M), s] Drake integrates, with A and b read off the same functions
    `DmpSource` calls (`transformation_matrices`, `canonical_phase_rate`). No Python runs
    while it is simulated.

    Parameters
    ----------
    dmp : Dmp
        The fitted DMP (with a new goal already set, if any).
    duration : float
        How long the source will be simulated [s]; the forcing is sampled that far.
    tau : float, optional
        Time constant [s]; default the demonstration's (another value: temporal scaling).

    Returns
    -------
    Diagram
        Named "reference", without input ports; its output ports, as `DmpSource`'s (M task
        axes, the DMP's `n_axes`):

        - ``desired_position`` (M): x_d = p [m].
        - ``desired_velocity`` (M): x_d' = z / tau [m/s].
        - ``desired_acceleration`` (M): x_d'' = z' / tau [m/s^2].
        - ``phase`` (1): the canonical phase s [-] (Eq. 8).
    """
    tau = dmp.tau if tau is None else float(tau)
    m, settings = dmp.n_axes, dmp.settings
    a, b = transformation_matrices(tau, settings.alpha, settings.beta_value)
    eye = np.eye(m)
    state_matrix = np.zeros((2 * m + 1, 2 * m + 1))
    state_matrix[: 2 * m, : 2 * m] = np.kron(a, eye)
    state_matrix[2 * m, 2 * m] = canonical_phase_rate(1.0, tau, settings.alpha_s)
    input_matrix = np.vstack([np.kron(b[:, None], eye), np.zeros((1, m))])
    drift = np.append(np.kron(b, settings.alpha * settings.beta_value * dmp.goal), 0.0)
    # Outputs: x_d = p, x_d' = z / tau, x_d'' = z' / tau, and s.
    z_rows = slice(m, 2 * m)
    output_matrix = np.vstack(
        [
            np.eye(m, 2 * m + 1),
            np.eye(m, 2 * m + 1, m) / tau,
            state_matrix[z_rows] / tau,
            np.eye(1, 2 * m + 1, 2 * m),
        ]
    )
    feedthrough = np.vstack([np.zeros((2 * m, m)), input_matrix[z_rows] / tau, np.zeros((1, m))])
    output_offset = np.concatenate([np.zeros(2 * m), drift[z_rows] / tau, [0.0]])
    builder = DiagramBuilder()
    affine = builder.AddSystem(
        AffineSystem(state_matrix, input_matrix, drift, output_matrix, feedthrough, output_offset)
    )
    affine.set_name("transformation_system")
    affine.configure_default_state(np.concatenate([dmp.start, np.zeros(m), [1.0]]))
    times = np.arange(0.0, duration + 2 * FORCING_SAMPLE_S, FORCING_SAMPLE_S)
    forcing = dmp.forcing(phase_at(times, tau, settings.alpha_s))
    spline = PiecewisePolynomial.CubicWithContinuousSecondDerivatives(times, forcing.T, False)
    source = builder.AddSystem(TrajectorySource(spline))
    source.set_name("forcing_term")
    builder.Connect(source.get_output_port(), affine.get_input_port())
    split = builder.AddSystem(Demultiplexer([m, m, m, 1]))
    builder.Connect(affine.get_output_port(), split.get_input_port())
    for k, name in enumerate(
        ("desired_position", "desired_velocity", "desired_acceleration", "phase")
    ):
        builder.ExportOutput(split.get_output_port(k), name)
    diagram = builder.Build()
    diagram.set_name("reference")
    return diagram


class OrientationFromError(LeafSystem):
    """The orientation q = Exp(-e/2) q_g, its angular velocity and acceleration (world
    frame) from the rotation vector e to a goal at rest and e's first two derivatives
    (`core.orientation_dmp`: `orientation_from_error`, `angular_velocity`,
    `angular_acceleration`), evaluated once per input change.

    Input ports:

    - ``rotation_error`` (3): e [rad].
    - ``rotation_error_rate`` (3): e' [rad/s].
    - ``rotation_error_acceleration`` (3): e'' [rad/s^2].

    Output ports:

    - ``desired_orientation`` (4): q (w, x, y, z).
    - ``desired_angular_velocity`` (3): omega [rad/s], world frame.
    - ``desired_angular_acceleration`` (3): omega' [rad/s^2], world frame.

    Parameters
    ----------
    goal : (4,) array_like
        q_g, a unit quaternion.
    """

    def __init__(self, goal):
        super().__init__()
        self._goal = np.asarray(goal, dtype=float)
        self._inputs = [
            self.DeclareVectorInputPort(name, 3)
            for name in ("rotation_error", "rotation_error_rate", "rotation_error_acceleration")
        ]
        self._values = self.DeclareCacheEntry(
            "orientation",
            ValueProducer(allocate=lambda: AbstractValue.Make(None), calc=self._calc_values),
            {self.all_input_ports_ticket()},
        )
        ticket = {self._values.ticket()}
        for k, (name, size) in enumerate(
            (
                ("desired_orientation", 4),
                ("desired_angular_velocity", 3),
                ("desired_angular_acceleration", 3),
            )
        ):
            self.DeclareVectorOutputPort(
                name, size, lambda c, o, k=k: o.SetFromVector(self._values.Eval(c)[k]), ticket
            )

    def _calc_values(self, context, abstract_value):
        e, rate, acceleration = (port.Eval(context) for port in self._inputs)
        abstract_value.set_value(
            (
                orientation_from_error(e, self._goal),
                angular_velocity(e, rate, np.zeros(3)),
                angular_acceleration(e, rate, acceleration),
            )
        )


def orientation_dmp_source(
    dmp: OrientationDmp, duration: float, tau: float | None = None
) -> Diagram:
    """The orientation DMP for its present goal: the transformation system in e
    (`OrientationDmp.error_dmp`, linear) as Drake's own C++ systems (`linear_dmp_source`),
    and the map to the orientation (`OrientationFromError`, Python, run only when its
    ports are evaluated).

    Parameters
    ----------
    dmp : OrientationDmp
        The fitted orientation DMP (with a new goal already set, if any).
    duration : float
        How long the source will be simulated [s].
    tau : float, optional
        Time constant [s]; default the demonstration's (another value: temporal scaling).

    Returns
    -------
    Diagram
        Named "orientation_reference", without input ports; output ports:

        - ``rotation_error``, ``rotation_error_rate``, ``rotation_error_acceleration``
          (3 each): e [rad], e' [rad/s], e'' [rad/s^2], from the C++ systems alone.
        - ``desired_orientation`` (4), ``desired_angular_velocity`` (3),
          ``desired_angular_acceleration`` (3): q_d (w, x, y, z), omega_d [rad/s] and
          omega_d' [rad/s^2] in the world frame.
        - ``phase`` (1): the canonical phase s [-] (Eq. 8).
    """
    builder = DiagramBuilder()
    error = builder.AddSystem(linear_dmp_source(dmp.error_dmp(), duration, tau))
    error.set_name("rotation_error_dmp")
    to_orientation = builder.AddSystem(OrientationFromError(dmp.goal))
    to_orientation.set_name("orientation_from_error")
    for source, target in (
        ("desired_position", "rotation_error"),
        ("desired_velocity", "rotation_error_rate"),
        ("desired_acceleration", "rotation_error_acceleration"),
    ):
        builder.Connect(error.GetOutputPort(source), to_orientation.GetInputPort(target))
        builder.ExportOutput(error.GetOutputPort(source), target)
    for name in (
        "desired_orientation",
        "desired_angular_velocity",
        "desired_angular_acceleration",
    ):
        builder.ExportOutput(to_orientation.GetOutputPort(name), name)
    builder.ExportOutput(error.GetOutputPort("phase"), "phase")
    diagram = builder.Build()
    diagram.set_name("orientation_reference")
    return diagram


class StepReference(LeafSystem):
    """A piecewise-constant desired position (x_d' = x_d'' = 0) with the DMP's canonical
    phase (Eq. 8) as continuous state, for tasks defined by set-points, such as the
    paper's 1-DOF comparison (x_d = -0.15 m from t = 0, x_d = 0 from t = 10 s).

    Input ports: none.

    Output ports (M task-space axes, the columns of `positions`):

    - ``desired_position`` (M): x_d [m], the row of `positions` in force at the context's
      time (see `position_at`).
    - ``desired_velocity``, ``desired_acceleration`` (M): x_d' [m/s] and x_d'' [m/s^2],
      always zero.
    - ``phase`` (1): the canonical phase s [-], continuous state from s(0) = 1 with
      tau s' = -alpha_s s (Eq. 8).

    Parameters
    ----------
    times : (K,) array_like
        The switch times [s], increasing, times[0] = 0.
    positions : (K, M) array_like
        The set-points x_d [m]: row k holds from times[k] on (K * M values in any shape are
        reshaped to K rows).
    tau : float
        The phase's time constant [s] (the scenarios pass the run's `duration_s`).
    alpha_s : float
        The canonical system's decay rate [-], > 0 (the scenario's `dmp.alpha_s`).
    """

    def __init__(self, times, positions, tau, alpha_s):
        super().__init__()
        self._times = np.asarray(times, dtype=float)
        self._positions = np.asarray(positions, dtype=float).reshape(len(self._times), -1)
        self._tau, self._alpha_s = float(tau), float(alpha_s)
        m = self._positions.shape[1]
        self.DeclareContinuousState(BasicVector([1.0]), 0, 0, 1)
        self.DeclareVectorOutputPort(
            "desired_position", m, self._calc_position, {self.time_ticket()}
        )
        zero = {self.nothing_ticket()}
        self.DeclareVectorOutputPort("desired_velocity", m, lambda c, o: o.SetZero(), zero)
        self.DeclareVectorOutputPort("desired_acceleration", m, lambda c, o: o.SetZero(), zero)
        self.DeclareVectorOutputPort("phase", 1, self._calc_phase, {self.all_state_ticket()})

    def position_at(self, t: float) -> np.ndarray:
        """The set-point in force at time t: the last row of `positions` whose switch
        time is <= t (the first row before times[0]).

        Parameters
        ----------
        t : float
            Time [s].

        Returns
        -------
        (M,) array
            Desired position x_d [m].
        """
        index = np.searchsorted(self._times, t, side="right") - 1
        return self._positions[max(index, 0)]

    def DoCalcTimeDerivatives(self, context, derivatives):
        s = context.get_continuous_state_vector()[0]
        derivatives.get_mutable_vector().SetFromVector(
            [canonical_phase_rate(s, self._tau, self._alpha_s)]
        )

    def _calc_position(self, context, output):
        output.SetFromVector(self.position_at(context.get_time()))

    def _calc_phase(self, context, output):
        output.SetFromVector([context.get_continuous_state_vector()[0]])


def compiled_step_reference(
    times: np.ndarray, positions: np.ndarray, tau: float, alpha_s: float
) -> Diagram:
    """`StepReference` as Drake's own C++ systems, with its ports and values: the set-points
    as a zero-order-hold trajectory (right-continuous at a switch time, as
    `StepReference.position_at`), zero x_d' and x_d'', and the phase of Eq. 8 as the
    state of an AffineSystem (A read off `canonical_phase_rate`). No Python runs while it
    is simulated.

    Parameters
    ----------
    times, positions, tau, alpha_s
        As for `StepReference`.

    Returns
    -------
    Diagram
        Named "reference", without input ports; output ports ``desired_position``,
        ``desired_velocity``, ``desired_acceleration`` (M) and ``phase`` (1), as
        `StepReference`'s.
    """
    times = np.asarray(times, dtype=float)
    positions = np.asarray(positions, dtype=float).reshape(len(times), -1)
    m = positions.shape[1]
    # One more break after the last switch, so that the last set-point holds for ever
    # (a zero-order hold's last sample only marks where its last segment ends).
    breaks = np.append(times, times[-1] + 1.0)
    samples = np.vstack([positions, positions[-1:]]).T
    builder = DiagramBuilder()
    set_points = builder.AddSystem(
        TrajectorySource(PiecewisePolynomial.ZeroOrderHold(breaks, samples))
    )
    set_points.set_name("set_points")
    builder.ExportOutput(set_points.get_output_port(), "desired_position")
    # State s; outputs [x_d' (M), x_d'' (M), s] = [0, 0, s].
    phase = builder.AddSystem(
        AffineSystem(
            A=[[canonical_phase_rate(1.0, tau, alpha_s)]],
            B=np.zeros((1, 0)),
            f0=[0.0],
            C=np.vstack([np.zeros((2 * m, 1)), [[1.0]]]),
            D=np.zeros((2 * m + 1, 0)),
            y0=np.zeros(2 * m + 1),
        )
    )
    phase.set_name("phase")
    phase.configure_default_state([1.0])
    split = builder.AddSystem(Demultiplexer([m, m, 1]))
    builder.Connect(phase.get_output_port(), split.get_input_port())
    for k, name in enumerate(("desired_velocity", "desired_acceleration", "phase")):
        builder.ExportOutput(split.get_output_port(k), name)
    diagram = builder.Build()
    diagram.set_name("reference")
    return diagram
