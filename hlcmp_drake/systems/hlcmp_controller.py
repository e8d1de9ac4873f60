"""The Hl-CMP adaptive controller as a Drake system (paper Eqs. 4-5, 14, 16, 29, 31, 33-34)."""

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, ValueProducer

from hlcmp_drake.core.laws import HlcmpGains, HlcmpLaw
from hlcmp_drake.systems.ports import declare_task_space_inputs


class HlcmpController(LeafSystem):
    """Learns stiffness, damping and feed-forward force online while tracking x_d.

    Continuous state: theta = [theta_k, theta_d, theta_v], each (M, N) row-major, so Drake
    integrates the adaptation law Eq. 31 at every integrator stage. Outputs: `force` f_c
    (Eq. 33), and for logging `stiffness`, `damping` (diagonals of K_s, K_d), `feedforward`
    v (Eq. 14), `impedance_force` u (Eq. 4) and `sliding_error` eps (Eq. 29). The law
    itself is `core.laws.HlcmpLaw`, which the arm's one-call loop evaluates too.
    """

    def __init__(self, centers, widths, gains: HlcmpGains, theta0=None):
        super().__init__()
        self._law = HlcmpLaw(centers, widths, gains)
        m, size = self._law.n_axes, self._law.theta_size
        self._m = m
        self.inputs = declare_task_space_inputs(self, m)
        theta0 = np.zeros(size) if theta0 is None else np.asarray(theta0, dtype=float).ravel()
        if theta0.size != size:
            raise ValueError(f"theta0 must hold 3*M*N = {size} values, got {theta0.size}")
        self.DeclareContinuousState(BasicVector(theta0), 0, 0, size)
        # Every output depends on the measured and desired motion, the phase and theta.
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
        for name in self._law.log_fields:
            self.DeclareVectorOutputPort(name, m, self._log_output(name), {self._terms.ticket()})

    def theta(self, context: Context) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(theta_k, theta_d, theta_v) from a context of this system, each (M, N).

        Parameters
        ----------
        context : Context
            A context of this system.

        Returns
        -------
        theta_k, theta_d, theta_v : (M, N) arrays
            Weights of the stiffness [N/m], damping [N s/m] and feed-forward force [N]
            profiles, copied from the continuous state.
        """
        return self._law.unflatten(context.get_continuous_state_vector().CopyToVector())

    def _calc_terms(self, context, abstract_value):
        theta = context.get_continuous_state_vector().CopyToVector()
        abstract_value.set_value(self._law.command(self.inputs.instant(context, self._m), theta))

    def _log_output(self, name):
        def calc(context, output):
            output.SetFromVector(self._terms.Eval(context).logs[name])

        return calc

    def DoCalcTimeDerivatives(self, context, derivatives):
        derivatives.get_mutable_vector().SetFromVector(self._terms.Eval(context).rates)
