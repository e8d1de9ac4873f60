"""The baseline controller without a `core.laws` law as a Drake system: the variable-impedance
controller of Duan et al. 2018 standing in for the paper's ref. [21] (see
`hlcmp_drake.core.duan2018` for its equations and citation)."""

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

from hlcmp_drake.core.duan2018 import (
    duan_commanded_motion,
    duan_phi_update,
    inner_position_loop,
)
from hlcmp_drake.systems.ports import declare_task_space_inputs


class VariableImpedanceController(LeafSystem):
    """Force-tracking adaptive variable impedance (Duan et al. 2018), position based.

    Continuous state: the commanded position x_c and velocity x_c' (M each), integrated
    from the target impedance. Discrete state: Phi (M), updated every `sample_period`
    (lambda) by Phi(t) = Phi(t - lambda) + sigma Delta_f(t - lambda) / b.
    Extra input `external_force` (the wrist sensor's reaction force, M); desired force
    per reference segment: `desired_force(t)` returns f_d (M), and segments with f_d = 0
    use the plain impedance with `free_stiffness` and Phi held at zero.

    Input ports (M task-space axes), the standard controller inputs
    (`declare_task_space_inputs`) and one more:

    - ``position``, ``velocity`` (M): measured x [m], x' [m/s].
    - ``desired_position``, ``desired_velocity``, ``desired_acceleration`` (M): the
      reference x_r [m], x_r' [m/s], x_r'' [m/s^2] that the admittance is written about.
    - ``phase`` (1): the canonical phase s [-]; declared so the controller is
      interchangeable with the others, not read.
    - ``task_inertia``, ``task_coriolis`` (M * M, row-major): Λ [kg], C [kg/s], for the
      inner loop.
    - ``task_gravity`` (M): G [N].
    - ``external_force`` (M): the measured reaction force f_e of the environment on the
      robot [N] (e.g. `ToolContactForce`'s ``task_force``).

    Output ports:

    - ``force`` (M): the commanded task-space force f [N] of the inner inverse-dynamics
      PD loop tracking x_c (`inner_position_loop`).

    Parameters
    ----------
    mass : (M,) array_like
        Target mass m [kg], > 0.
    damping : (M,) array_like
        Target damping b [N s/m], > 0.
    free_stiffness : (M,) array_like
        Target stiffness k [N/m] where f_d = 0 (0 while tracking a force), >= 0.
    sigma : float
        The adaptation's update rate sigma [-], >= 0.
    sample_period : float
        lambda, the period of Phi's update [s], > 0.
    kp : (M,) array_like
        Inner-loop position gain [1/s^2].
    kv : (M,) array_like
        Inner-loop velocity gain [1/s].
    desired_force : callable(t) -> (M,) array
        f_d at time t [s]: the desired reaction force [N], 0 on an axis where the task
        asks for none.
    initial_position : (M,) array_like
        x_c(0) [m] (x_c'(0) = 0): the task-space position at t = 0.
    """

    def __init__(
        self,
        mass,
        damping,
        free_stiffness,
        sigma,
        sample_period,
        kp,
        kv,
        desired_force,
        initial_position,
    ):
        super().__init__()
        self._mass, self._damping = np.asarray(mass, float), np.asarray(damping, float)
        self._free_stiffness, self._sigma = np.asarray(free_stiffness, float), float(sigma)
        self._kp, self._kv = np.asarray(kp, float), np.asarray(kv, float)
        self._desired_force = desired_force
        m = len(self._mass)
        self._m = m
        self.inputs = declare_task_space_inputs(self, m)
        self.external_force = self.DeclareVectorInputPort("external_force", BasicVector(m))
        self.DeclareContinuousState(
            BasicVector(np.concatenate([initial_position, np.zeros(m)])), 0, 0, 2 * m
        )
        self._phi = self.DeclareDiscreteState(m)
        self.DeclarePeriodicDiscreteUpdateEvent(sample_period, 0.0, self._update_phi)
        self.DeclareVectorOutputPort(
            "force",
            m,
            self._calc_force,
            {self.all_input_ports_ticket(), self.all_state_ticket(), self.time_ticket()},
        )

    def _admittance(self, context):
        """(x_c, x_c', x_c'', Delta_f, tracking) at this context."""
        xc_all = context.get_continuous_state_vector().CopyToVector()
        xc, xc_dot = xc_all[: self._m], xc_all[self._m :]
        _, _, xr, xr_dot, xr_ddot = self.inputs.errors_and_reference(context)
        xc_ddot, delta_f, tracking = duan_commanded_motion(
            xc,
            xc_dot,
            context.get_discrete_state(self._phi).get_value(),
            xr,
            xr_dot,
            xr_ddot,
            self._desired_force(context.get_time()),
            self.external_force.Eval(context),
            self._mass,
            self._damping,
            self._free_stiffness,
        )
        return xc, xc_dot, xc_ddot, delta_f, tracking

    def _update_phi(self, context, discrete_state):
        _, _, _, delta_f, tracking = self._admittance(context)
        phi = context.get_discrete_state(self._phi).get_value()
        discrete_state.get_mutable_vector(self._phi).SetFromVector(
            duan_phi_update(phi, delta_f, tracking, self._sigma, self._damping)
        )

    def DoCalcTimeDerivatives(self, context, derivatives):
        _, xc_dot, xc_ddot, _, _ = self._admittance(context)
        derivatives.get_mutable_vector().SetFromVector(np.concatenate([xc_dot, xc_ddot]))

    def _calc_force(self, context, output):
        xc, xc_dot, xc_ddot, _, _ = self._admittance(context)
        x, xdot = self.inputs.position.Eval(context), self.inputs.velocity.Eval(context)
        inertia, coriolis, gravity = self.inputs.dynamics(context, self._m)
        output.SetFromVector(
            inner_position_loop(
                inertia,
                coriolis @ xdot,
                gravity,
                xc_ddot,
                xc_dot,
                xc,
                x,
                xdot,
                self._kp,
                self._kv,
                self.external_force.Eval(context),
            )
        )
