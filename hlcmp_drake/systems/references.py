"""Desired-motion sources: the DMP (paper Eqs. 6-8, 13, 15) and a step reference.

Both have the same output ports -- desired_position, desired_velocity,
desired_acceleration (M each) and phase (1) -- so a controller cannot tell them apart.
"""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, LeafSystem, ValueProducer

from hlcmp_drake.core.dmp import Dmp, canonical_phase_rate


class DmpSource(LeafSystem):
    """A fitted DMP as a Drake system. Continuous state [p (M), z (M), s]; Drake integrates
    Eqs. 7, 8 and 15 through `Dmp.rates`. tau may differ from the demonstration's
    (temporal scaling); a new goal is set with `Dmp.with_goal` before construction."""

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
            "dmp_rates", ValueProducer(allocate=lambda: AbstractValue.Make(None), calc=self._calc_rates),
            state)
        self.DeclareVectorOutputPort("desired_position", m, self._calc_position, state)
        self.DeclareVectorOutputPort("desired_velocity", m, self._calc_velocity, state)
        self.DeclareVectorOutputPort("desired_acceleration", m, self._calc_acceleration,
                                     {self._rates.ticket()})
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


class StepReference(LeafSystem):
    """A piecewise-constant desired position (x_d' = x_d'' = 0) with the DMP's canonical
    phase (Eq. 8) as continuous state, for tasks defined by set-points, such as the
    paper's 1-DOF comparison (x_d = -0.15 m from t = 0, x_d = 0 from t = 10 s).

    times: (K,) switch times, increasing, times[0] = 0; positions: (K, M).
    """

    def __init__(self, times, positions, tau, alpha_s):
        super().__init__()
        self._times = np.asarray(times, dtype=float)
        self._positions = np.asarray(positions, dtype=float).reshape(len(self._times), -1)
        self._tau, self._alpha_s = float(tau), float(alpha_s)
        m = self._positions.shape[1]
        self.DeclareContinuousState(BasicVector([1.0]), 0, 0, 1)
        self.DeclareVectorOutputPort("desired_position", m, self._calc_position,
                                     {self.time_ticket()})
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
        derivatives.get_mutable_vector().SetFromVector([canonical_phase_rate(s, self._tau, self._alpha_s)])

    def _calc_position(self, context, output):
        output.SetFromVector(self.position_at(context.get_time()))

    def _calc_phase(self, context, output):
        output.SetFromVector([context.get_continuous_state_vector()[0]])
