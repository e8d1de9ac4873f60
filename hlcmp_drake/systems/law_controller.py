"""Any task-space law of `core.laws` as one Drake system (the modular path)."""

from __future__ import annotations

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, ValueProducer

from hlcmp_drake.core.laws import ControlLaw
from hlcmp_drake.systems.ports import declare_task_space_inputs


class LawController(LeafSystem):
    """A `core.laws` law (the Hl-CMP, its forgetting variant, the constant impedance) as a
    Drake system, evaluated port by port.

    For a law that learns, θ = [θ_k, θ_d, θ_v] (each (M, N) row-major) is the system's
    continuous state and its time derivative is the law's rate (Eq. 31, or the law's own
    variant), so Drake integrates the adaptation at every integrator stage.

    Input ports (M task-space axes):

    - ``position``, ``velocity`` (M): measured x [m], x' [m/s].
    - ``desired_position``, ``desired_velocity``, ``desired_acceleration`` (M): x_d [m],
      x_d' [m/s], x_d'' [m/s^2] from the reference.
    - ``phase`` (1): the canonical phase s [-].
    - ``task_inertia``, ``task_coriolis`` (M * M, row-major): Λ [kg], C [kg/s].
    - ``task_gravity`` (M): G [N].

    Output ports:

    - ``force`` (M): the commanded task-space force f_c [N] (Eq. 33).
    - one (M) port per key of the law's `log_fields`; for the Hl-CMP ``stiffness`` [N/m],
      ``damping`` [N s/m] (diagonals of K_s, K_d, Eq. 16), ``feedforward`` v [N] (Eq. 14),
      ``impedance_force`` u [N] (Eq. 4), ``sliding_error`` ε [m/s] (Eq. 29).

    Parameters
    ----------
    law : ControlLaw
        The law evaluated at every output and derivative evaluation.
    theta0 : (P,) array, optional
        The initial flattened θ of a learning law (default zeros); ignored otherwise.

    Raises
    ------
    ValueError
        When `theta0` does not hold the law's `theta_size` values.
    """

    def __init__(self, law: ControlLaw, theta0: np.ndarray | None = None):
        super().__init__()
        self.law = law
        m = law.n_axes
        self._m = m
        self.inputs = declare_task_space_inputs(self, m)
        if law.learns:
            size = law.theta_size
            start = np.zeros(size) if theta0 is None else np.asarray(theta0, dtype=float).ravel()
            if start.size != size:
                raise ValueError(f"theta0 must hold 3*M*N = {size} values, got {start.size}")
            self.DeclareContinuousState(BasicVector(start), 0, 0, size)
        # Every output depends on the measured and desired motion, the phase and θ.
        self._terms = self.DeclareCacheEntry(
            "control_terms",
            ValueProducer(allocate=lambda: AbstractValue.Make(None), calc=self._calc_terms),
            {self.all_input_ports_ticket(), self.all_state_ticket()},
        )
        self.DeclareVectorOutputPort(
            "force",
            m,
            lambda c, o: o.SetFromVector(self._terms.Eval(c).force),
            {self._terms.ticket()},
        )
        for name in law.log_fields:
            self.DeclareVectorOutputPort(name, m, self._log_output(name), {self._terms.ticket()})

    def theta(self, context: Context) -> tuple[np.ndarray, ...]:
        """The law's weights from a context of this system.

        Parameters
        ----------
        context : Context
            A context of this system.

        Returns
        -------
        tuple of (M, N) arrays
            For the Hl-CMP (θ_k, θ_d, θ_v): the weights of the stiffness [N/m], damping
            [N s/m] and feed-forward force [N] profiles, copied from the continuous state;
            empty for a law that does not learn.
        """
        return self.law.unflatten(self._theta_vector(context))

    def _theta_vector(self, context: Context) -> np.ndarray:
        if not self.law.learns:
            return np.zeros(0)
        return context.get_continuous_state_vector().CopyToVector()

    def _calc_terms(self, context, abstract_value):
        now = self.inputs.instant(context, self._m)
        abstract_value.set_value(self.law.command(now, self._theta_vector(context)))

    def _log_output(self, name):
        def calc(context, output):
            output.SetFromVector(self._terms.Eval(context).logs[name])

        return calc

    def DoCalcTimeDerivatives(self, context, derivatives):
        if self.law.learns:
            derivatives.get_mutable_vector().SetFromVector(self._terms.Eval(context).rates)
