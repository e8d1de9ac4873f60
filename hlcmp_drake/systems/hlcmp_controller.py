"""The Hl-CMP adaptive controller as a Drake system (paper Eqs. 4-5, 14, 16, 29, 31, 33-34)."""

from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, LeafSystem, ValueProducer

from hlcmp_drake.core.adaptation import adaptation_rates, compliant_profiles
from hlcmp_drake.core.control_law import commanded_force, impedance_force, nominal_command
from hlcmp_drake.core.dmp import normalized_basis
from hlcmp_drake.systems.ports import declare_task_space_inputs


@dataclass(frozen=True)
class HlcmpGains:
    """Per-axis learning rates Q_k, Q_d, Q_v (M,), the sliding-surface slope pi > 0 and the
    diagonal of the feedback gain L (M,) of Eq. 34."""

    q_k: np.ndarray
    q_d: np.ndarray
    q_v: np.ndarray
    pi: float
    gain_l: np.ndarray


class HlcmpController(LeafSystem):
    """Learns stiffness, damping and feed-forward force online while tracking x_d.

    Continuous state: theta = [theta_k, theta_d, theta_v], each (M, N) row-major, so Drake
    integrates the adaptation law Eq. 31. Outputs: `force` f_c (Eq. 33), and for logging
    `stiffness`, `damping` (diagonals of K_s, K_d), `feedforward` v (Eq. 14),
    `impedance_force` u (Eq. 4) and `sliding_error` eps (Eq. 29).
    """

    def __init__(self, centers, widths, gains: HlcmpGains, theta0=None):
        super().__init__()
        self._centers, self._widths = np.asarray(centers), np.asarray(widths)
        self._gains = gains
        m, n = len(gains.q_k), len(self._centers)
        self._m, self._n = m, n
        self.inputs = declare_task_space_inputs(self, m)
        theta0 = np.zeros(3 * m * n) if theta0 is None else np.asarray(theta0, dtype=float).ravel()
        if theta0.size != 3 * m * n:
            raise ValueError(f"theta0 must hold 3*M*N = {3 * m * n} values, got {theta0.size}")
        self.DeclareContinuousState(BasicVector(theta0), 0, 0, 3 * m * n)
        # Every output depends on the measured and desired motion, the phase and theta.
        self._terms = self.DeclareCacheEntry(
            "control_terms",
            ValueProducer(allocate=lambda: AbstractValue.Make(_ControlTerms(m)),
                          calc=self._calc_terms),
            {self.all_input_ports_ticket(), self.all_state_ticket()})
        for name, field in [("force", "force"), ("stiffness", "k_s"), ("damping", "k_d"),
                            ("feedforward", "v"), ("impedance_force", "u"), ("sliding_error", "eps")]:
            self.DeclareVectorOutputPort(name, m, self._output_from(field), {self._terms.ticket()})

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
        flat = context.get_continuous_state_vector().CopyToVector()
        return tuple(flat.reshape(3, self._m, self._n))

    def _calc_terms(self, context, abstract_value):
        x, xdot, xd, xd_dot, xd_ddot = self.inputs.errors_and_reference(context)
        inertia, coriolis, gravity = self.inputs.dynamics(context, self._m)
        g = normalized_basis(self.inputs.phase.Eval(context)[0], self._centers, self._widths)
        theta_k, theta_d, theta_v = self.theta(context)
        e, edot, eps, f0 = nominal_command(x, xdot, xd, xd_dot, xd_ddot, inertia, coriolis, gravity,
                                           self._gains.pi, self._gains.gain_l)
        k_s, k_d, v = compliant_profiles(theta_k, theta_d, theta_v, g)
        terms = abstract_value.get_mutable_value()
        u = impedance_force(k_s, k_d, e, edot)
        terms.force[:] = commanded_force(f0, u, v)
        terms.k_s[:], terms.k_d[:], terms.v[:], terms.u[:], terms.eps[:] = k_s, k_d, v, u, eps
        terms.e[:], terms.edot[:], terms.g = e, edot, g

    def _output_from(self, field):
        def calc(context, output):
            output.SetFromVector(getattr(self._terms.Eval(context), field))
        return calc

    def DoCalcTimeDerivatives(self, context, derivatives):
        terms = self._terms.Eval(context)
        rates = adaptation_rates(terms.eps, terms.e, terms.edot, terms.g,
                                 self._gains.q_k, self._gains.q_d, self._gains.q_v)
        derivatives.get_mutable_vector().SetFromVector(np.concatenate([r.ravel() for r in rates]))


class _ControlTerms:
    """Scratch values of one controller evaluation, kept in a Drake cache entry."""

    def __init__(self, m):
        self.force, self.k_s, self.k_d, self.v, self.u, self.eps, self.e, self.edot = (
            np.zeros(m) for _ in range(8))
        self.g = None
