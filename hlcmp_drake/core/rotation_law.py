"""The rotational Hl-CMP and the 6-D (pose) task-space laws. Pure numpy; the equations and
their compositions are `jitable` (`core.kernels`), compiled or numpy as `PoseLaw` says.

The paper's law (Eqs. 4-5, 14, 29, 31, 33-34) is written for the tool point's translation.
Its rotational analogue, on the same phase basis, uses

.. math:: e_r = \\operatorname{Log}(R_d^T R)^\\vee, \\qquad
          \\omega_e = R^T (\\omega - \\omega_d), \\qquad
          \\varepsilon_r = \\omega_e + \\pi_r e_r

in place of (e, e', eps), with R, R_d the tool frame's measured and desired orientations in
the world and omega, omega_d their world-frame angular velocities.

**The axes are the tool frame's.** R_d^T R is the measured tool frame seen from the desired
one, so e_r's components are about the tool's own axes; e_r is the axis of R_d^T R, which
that rotation leaves fixed, so its components are the same in the desired and in the
measured tool frame. omega_e = R^T (omega - omega_d) is the body angular velocity of
R_d^T R (d/dt (R_d^T R) = (R_d^T R) [omega_e]x), in the measured tool frame. A diagonal
K_r = diag(K_r,x, K_r,y, K_r,z) then has a meaning that moves with the tool: for a peg
along its z axis, K_r,z is the stiffness about the peg's own axis and K_r,x, K_r,y the
stiffness against tilting, whatever the tool's pose in the world; in the world frame the
same diagonal would mix the two as the tool turns. The law's torques (K_r e_r, D_r
omega_e, v_r, L_r eps_r) are tool-frame torques, rotated to the world by R once, in
`rotational_torque`.

**The sliding surface is exact.** The rate of e_r is J_r(e_r)^-1 omega_e, J_r the right
Jacobian of SO(3) (= `quaternion.left_jacobian`(-e_r)); eps_r uses omega_e itself, as
the issue and SPEC Sec. 9 write it. On eps_r = 0, omega_e = -pi_r e_r, and since
J_r(e)^-1 e = e, e_r' = -pi_r e_r: the error shrinks along a fixed axis at the rate pi_r,
exactly as the translational e does on eps = 0.

**Near a rotation of pi.** e_r is the principal rotation vector (`quaternion.
to_rotation_vector`), |e_r| <= pi, so every error term is bounded: |K_r e_r| <= pi max
K_r. As the error passes pi the shortest way back switches to the other side and e_r
jumps from about pi a to about -pi a (a the axis): the restoring torque reverses, turning
the tool the short way, which is correct for an error beyond pi but a discontinuity of
the command; exactly at pi the axis of `to_rotation_vector` is returned (q's vector part
for w >= 0). The controller does nothing special there: an error near pi means the tool
is half a turn from its reference, far outside any contact task (the bundled worlds stay
within a few degrees), and a task that demonstrates large turns has them in the DMP's
reference R_d(t), not in the error. The learning law is bounded there too, since e_r is.
Seo et al. 2022's potential tr(I - R_d^T R) would avoid the switch, at the price of a
torque that vanishes at pi.

**The 6-D law** (`PoseLaw`) is the operational-space form of Eqs. 2 and 33-34 with the
spatial velocity V = [omega; x'] (Drake's order, angular rows first, world frame):

.. math:: \\Lambda \\dot V + \\mu + p = F + F_{ext}, \\qquad
          F_0 = \\Lambda \\dot V_e + C_x V_e + p, \\qquad
          F = F_0 - [R (L_r \\varepsilon_r + u_r + v_r);\\; L \\varepsilon + u + v]

with V_e = [omega_ref; x_e'] (`rotational_reference`, `control_law.reference_motion`) and
Lambda, C_x, p the 6-D task-space inertia, Coriolis and gravity from Drake
(`systems.spatial_task_space`). Where mu = C_x V (no self-motion of the arm) the closed
loop is Lambda eps_6' + (C_x + L_6) eps_6 + [R (u_r + v_r); u + v] = F_ext, with eps_6 =
V - V_e = [R eps_r; eps] and L_6 = diag(R L_r R^T, L): the paper's loop in 6-D.

Its translational half is a `core.laws` law called unchanged (the Hl-CMP of M = 3, or the
constant impedance), with the coupling to rotation in its inputs; its numbers equal the
3-D law's to the bit for the same inputs (tests/test_core_rotation_law.py). The
translational force differs from the 3-D world's only through the 6-D Lambda, C_x, p
(Lambda_vv is not the 3-D Lambda: rotation couples).

References
----------
O. Khatib, "A unified approach for motion and force control of robot manipulators: the
operational space formulation", IEEE J. Robotics and Automation 3(1), 1987.
F. Caccavale, C. Natale, B. Siciliano, L. Villani, "Six-DOF impedance control based on
angle/axis representations", IEEE Trans. Robotics and Automation 15(2), 1999 (the
rotational error in the tool frame).
J. Sola, J. Deray, D. Atchuthan, "A micro Lie theory for state estimation in robotics",
arXiv:1812.01537, 2018 (right Jacobian, body rates).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hlcmp_drake.core import quaternion as quat
from hlcmp_drake.core.control_law import impedance_force, sliding_error
from hlcmp_drake.core.kernels import implementation, jitable, kernel_path
from hlcmp_drake.core.laws import (
    ConstantImpedanceLaw,
    HlcmpGains,
    LawOutput,
    hlcmp_rates,
    impedance_motion,
    learned_impedance,
)


@jitable
def rotation_errors(
    q: np.ndarray, omega: np.ndarray, q_d: np.ndarray, omega_d: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The rotational analogue of Eq. 5, in the tool frame:
    e_r = Log(R_d^T R)^vee and omega_e = R^T (omega - omega_d).

    Parameters
    ----------
    q, q_d : (4,) arrays
        Measured and desired tool orientations in the world, unit quaternions (w, x, y, z);
        either sign.
    omega, omega_d : (3,) arrays
        Measured and desired angular velocities of the tool, world frame [rad/s].

    Returns
    -------
    e_r : (3,) array
        The principal rotation vector of R_d^T R [rad], |e_r| <= pi, tool frame.
    omega_e : (3,) array
        The angular velocity error [rad/s], the measured tool frame.
    """
    e_r = quat.to_rotation_vector(quat.multiply(quat.conjugate(q_d), q))
    omega_e = quat.to_matrix(q).T @ (omega - omega_d)
    return e_r, omega_e


@jitable
def rotational_reference(
    rotation: np.ndarray,
    omega: np.ndarray,
    e_r: np.ndarray,
    omega_e: np.ndarray,
    omega_d: np.ndarray,
    omega_d_dot: np.ndarray,
    pi: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The rotational analogue of Eq. 34's reference x_e' = x_d' - pi e: the world-frame
    angular velocity omega_ref for which eps_r = R^T (omega - omega_ref), and its rate.

    .. math:: \\omega_{ref} = \\omega_d - \\pi R e_r, \\qquad
              \\dot\\omega_{ref} = \\dot\\omega_d - \\pi (\\omega \\times R e_r
              + R J_r(e_r)^{-1} \\omega_e)

    (d/dt R e_r = omega x R e_r + R e_r', e_r' = J_r(e_r)^-1 omega_e, J_r(e) =
    `quaternion.left_jacobian`(-e), invertible for |e| < 2 pi, so for every principal e_r.)

    Parameters
    ----------
    rotation : (3, 3) array
        R, the measured tool orientation (`quaternion.to_matrix`).
    omega : (3,) array
        Measured angular velocity, world [rad/s].
    e_r, omega_e : (3,) arrays
        From `rotation_errors` [rad], [rad/s], tool frame.
    omega_d, omega_d_dot : (3,) arrays
        Desired angular velocity [rad/s] and acceleration [rad/s^2], world.
    pi : float
        Slope of the rotational sliding surface [1/s], > 0.

    Returns
    -------
    omega_ref, omega_ref_dot : (3,) arrays
        World frame [rad/s], [rad/s^2].
    """
    error_world = rotation @ e_r
    error_rate = np.linalg.solve(quat.left_jacobian(-e_r), omega_e)
    omega_ref = omega_d - pi * error_world
    omega_ref_dot = omega_d_dot - pi * (quat.cross(omega, error_world) + rotation @ error_rate)
    return omega_ref, omega_ref_dot


@jitable
def rotational_torque(
    torque_nominal: np.ndarray,
    rotation: np.ndarray,
    gain_l: np.ndarray,
    eps_r: np.ndarray,
    u_r: np.ndarray,
    v_r: np.ndarray,
) -> np.ndarray:
    """Eqs. 33-34's rotational analogue: the commanded torque
    tau_c = tau_0 - R (L_r eps_r + u_r + v_r), world frame.

    tau_0 is the rotational part of Lambda V_e' + C V_e + p (the Eq. 34 terms that come
    from the dynamics, world frame); the feedback L_r eps_r, the impedance torque
    u_r = K_r e_r + D_r omega_e (Eq. 4 with `control_law.impedance_force`) and the
    feed-forward v_r are per tool axis, so their sum is rotated to the world here.

    Parameters
    ----------
    torque_nominal : (3,) array
        tau_0 [N m], world.
    rotation : (3, 3) array
        R, the measured tool orientation (`quaternion.to_matrix`).
    gain_l : (3,) array
        Diagonal of L_r [N m s/rad], tool frame.
    eps_r : (3,) array
        Rotational sliding error [rad/s], tool frame.
    u_r, v_r : (3,) arrays
        Impedance and feed-forward torques [N m], tool frame.

    Returns
    -------
    (3,) array
        tau_c [N m], world.
    """
    return torque_nominal - rotation @ (gain_l * eps_r + u_r + v_r)


@dataclass(frozen=True)
class PoseInstant:
    """What a 6-D law reads at one instant: the tool point's measured and desired
    translation, the tool frame's measured and desired orientation, the phase, and the
    6-D task-space terms of Eq. 2 (from Drake, `systems.spatial_task_space`).

    The 6-D quantities are ordered as Drake's spatial vectors: angular first, then
    translational, world frame (V = [omega; x'], F = [tau; f]).

    Attributes
    ----------
    x, xdot, xd, xd_dot, xd_ddot : (3,) arrays
        As `laws.TaskSpaceInstant` [m], [m/s], [m/s^2], world.
    orientation, desired_orientation : (4,) arrays
        R and R_d of the tool frame in the world, unit quaternions (w, x, y, z).
    omega, omega_d : (3,) arrays
        Measured and desired angular velocity, world [rad/s].
    omega_d_dot : (3,) array
        Desired angular acceleration, world [rad/s^2].
    phase : float
        The canonical phase s [-].
    inertia : (6, 6) array
        Lambda [kg m^2, kg m, kg by block].
    coriolis : (6, 6) array, or an operator with `@` (`spatial_task_space.SpatialCoriolisProduct`)
        C_x of the spatial velocity; the laws form one product `coriolis @ V_e`.
    gravity : (6,) array
        p = Jbar^T G(q) [N m; N].
    """

    x: np.ndarray
    xdot: np.ndarray
    xd: np.ndarray
    xd_dot: np.ndarray
    xd_ddot: np.ndarray
    orientation: np.ndarray
    omega: np.ndarray
    desired_orientation: np.ndarray
    omega_d: np.ndarray
    omega_d_dot: np.ndarray
    phase: float
    inertia: np.ndarray
    coriolis: object
    gravity: np.ndarray


@jitable
def rotational_motion(
    q: np.ndarray,
    omega: np.ndarray,
    q_d: np.ndarray,
    omega_d: np.ndarray,
    omega_d_dot: np.ndarray,
    pi: float,
) -> np.ndarray:
    """The rotational analogue of `laws.impedance_motion` in one array: `rotation_errors`,
    eps_r (Eq. 29, `control_law.sliding_error`) and `rotational_reference`, then R.

    Parameters
    ----------
    q, q_d : (4,) arrays
        Measured and desired tool orientations, world, unit quaternions (w, x, y, z).
    omega, omega_d : (3,) arrays
        Measured and desired angular velocities, world [rad/s].
    omega_d_dot : (3,) array
        Desired angular acceleration, world [rad/s^2].
    pi : float
        pi_r [1/s].

    Returns
    -------
    (24,) array
        e_r [rad], omega_e [rad/s], eps_r [rad/s] (tool frame), omega_ref [rad/s],
        omega_ref' [rad/s^2] (world): the layout of `impedance_motion` with M = 3, which
        `laws.hlcmp_rates` reads; then R (`quaternion.to_matrix`), row-major.
    """
    e_r, omega_e = rotation_errors(q, omega, q_d, omega_d)
    rotation = quat.to_matrix(q)
    omega_ref, omega_ref_dot = rotational_reference(
        rotation, omega, e_r, omega_e, omega_d, omega_d_dot, pi
    )
    return np.concatenate(
        (e_r, omega_e, sliding_error(e_r, omega_e, pi), omega_ref, omega_ref_dot, rotation.ravel())
    )


@jitable
def pose_motion(
    x: np.ndarray,
    xdot: np.ndarray,
    xd: np.ndarray,
    xd_dot: np.ndarray,
    xd_ddot: np.ndarray,
    q: np.ndarray,
    omega: np.ndarray,
    q_d: np.ndarray,
    omega_d: np.ndarray,
    omega_d_dot: np.ndarray,
    pi: float,
    pi_r: float,
) -> np.ndarray:
    """What a 6-D law computes before C_x V_e: `laws.impedance_motion` (15,), then
    `rotational_motion` (24,).

    Parameters
    ----------
    x, xdot, xd, xd_dot, xd_ddot : (3,) arrays
        Measured and desired translation [m], [m/s], [m/s^2], world.
    q, omega, q_d, omega_d, omega_d_dot
        As for `rotational_motion`.
    pi, pi_r : float
        The translational and rotational slopes [1/s].

    Returns
    -------
    (39,) array
    """
    return np.concatenate(
        (
            impedance_motion(x, xdot, xd, xd_dot, xd_ddot, pi),
            rotational_motion(q, omega, q_d, omega_d, omega_d_dot, pi_r),
        )
    )


@jitable
def pose_nominal_split(
    motion: np.ndarray, inertia: np.ndarray, coriolis_term: np.ndarray, gravity: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lambda V_e' + C_x V_e + p by rows (`PoseLaw`): what the translational law takes in
    place of its Lambda and G_x, and the rotational rows tau_0.

    Parameters
    ----------
    motion : (39,) array
        From `pose_motion`.
    inertia : (6, 6) array
        Lambda.
    coriolis_term : (6,) array
        C_x V_e [N m; N].
    gravity : (6,) array
        p [N m; N].

    Returns
    -------
    translational_inertia : (3, 3) array
        Lambda_vv, contiguous.
    translational_gravity : (3,) array
        p_v + Lambda_vw omega_ref' [N].
    torque_nominal : (3,) array
        tau_0 = Lambda_ww omega_ref' + Lambda_wv x_e'' + (C_x V_e)_w + p_w [N m].
    """
    xe_ddot, omega_ref_dot = motion[12:15], motion[27:30]
    return (
        np.ascontiguousarray(inertia[3:, 3:]),
        gravity[3:] + np.ascontiguousarray(inertia[3:, :3]) @ omega_ref_dot,
        np.ascontiguousarray(inertia[:3, :3]) @ omega_ref_dot
        + np.ascontiguousarray(inertia[:3, 3:]) @ xe_ddot
        + coriolis_term[:3]
        + gravity[:3],
    )


@jitable
def rotational_hlcmp_torque(
    motion: np.ndarray,
    torque_nominal: np.ndarray,
    gain_l: np.ndarray,
    phase: float,
    theta: np.ndarray,
    centers: np.ndarray,
    widths: np.ndarray,
) -> np.ndarray:
    """The rotational Hl-CMP's command after `rotational_motion`: g(s) (Eq. 16), K_r, D_r,
    v_r (Eq. 14), u_r (Eq. 4) and tau_c (`rotational_torque`).

    Parameters
    ----------
    motion : (24,) array
        From `rotational_motion`.
    torque_nominal : (3,) array
        tau_0 [N m], world (`pose_nominal_split`).
    gain_l : (3,) array
        Diagonal of L_r [N m s/rad].
    phase : float
        s [-].
    theta : (9 N,) array
        [θ_kr, θ_dr, θ_vr], each (3, N) row-major.
    centers, widths : (N,) arrays
        The phase basis.

    Returns
    -------
    (18 + N,) array
        tau_c [N m] (world), K_r [N m/rad], D_r [N m s/rad], v_r [N m], u_r [N m], eps_r
        [rad/s] (tool frame), then g(s).
    """
    e_r, omega_e, eps_r = motion[:3], motion[3:6], motion[6:9]
    g, k_r, d_r, v_r, u_r = learned_impedance(phase, theta, centers, widths, e_r, omega_e)
    rotation = motion[15:].reshape(3, 3)
    torque = rotational_torque(torque_nominal, rotation, gain_l, eps_r, u_r, v_r)
    return np.concatenate((torque, k_r, d_r, v_r, u_r, eps_r, g))


@jitable
def rotational_impedance_torque(
    motion: np.ndarray,
    torque_nominal: np.ndarray,
    gain_l: np.ndarray,
    stiffness: np.ndarray,
    damping: np.ndarray,
) -> np.ndarray:
    """The constant rotational impedance's command after `rotational_motion`: u_r = K_r e_r +
    D_r omega_e (Eq. 4), v_r = 0, tau_c (`rotational_torque`).

    Parameters
    ----------
    motion, torque_nominal, gain_l
        As for `rotational_hlcmp_torque`.
    stiffness, damping : (3,) arrays
        Diagonals of K_r [N m/rad] and D_r [N m s/rad].

    Returns
    -------
    (3,) array
        tau_c [N m], world.
    """
    e_r, omega_e, eps_r = motion[:3], motion[3:6], motion[6:9]
    u_r = impedance_force(stiffness, damping, e_r, omega_e)
    rotation = motion[15:].reshape(3, 3)
    return rotational_torque(torque_nominal, rotation, gain_l, eps_r, u_r, np.zeros(3))


def spatial_coriolis_term(
    coriolis: object, omega_ref: np.ndarray, xe_dot: np.ndarray
) -> np.ndarray:
    """C_x V_e with V_e = [omega_ref; x_e']: the one product of Drake's operator; of a (6, 6)
    matrix by blocks, so that with no coupling (C_vw = 0) the translational rows are
    exactly C_vv x_e', as the 3-D law forms them.

    Parameters
    ----------
    coriolis : (6, 6) array or operator with `@`
        C_x, angular rows and columns first.
    omega_ref, xe_dot : (3,) arrays
        The reference velocities [rad/s], [m/s], world.

    Returns
    -------
    (6,) array
        [N m; N].
    """
    if isinstance(coriolis, np.ndarray):
        c = coriolis
        return np.concatenate(
            [c[:3, :3] @ omega_ref + c[:3, 3:] @ xe_dot, c[3:, 3:] @ xe_dot + c[3:, :3] @ omega_ref]
        )
    return coriolis @ np.concatenate([omega_ref, xe_dot])


class RotationalHlcmp:
    """K_r [N m/rad], D_r [N m s/rad] and v_r [N m] per tool axis on the phase basis
    (Eqs. 14, 16: `adaptation.compliant_profiles`), u_r = K_r e_r + D_r omega_e (Eq. 4:
    `control_law.impedance_force`), learned by Eq. 31 (`adaptation.adaptation_rates`, by way
    of `laws.hlcmp_rates`) with (e_r, omega_e, eps_r) in place of (e, e', eps); its
    arithmetic `rotational_hlcmp_torque`, compiled or numpy as `core.kernels.kernel_path`
    says when it is made.

    Parameters
    ----------
    centers, widths : (N,) arrays
        The phase basis, the translational law's.
    gains : HlcmpGains
        Q_kr, Q_dr, Q_vr per tool axis (>= 0), pi_r [1/s] and L_r [N m s/rad].
    """

    learns = True
    log_fields = {
        "rotational_stiffness": "Kr",
        "rotational_damping": "Dr",
        "rotational_feedforward": "vr",
        "impedance_torque": "ur",
        "rotational_sliding_error": "eps_r",
    }

    def __init__(self, centers: np.ndarray, widths: np.ndarray, gains: HlcmpGains):
        self.centers, self.widths = np.asarray(centers, float), np.asarray(widths, float)
        self.gains, self.n_basis = gains, len(self.centers)
        path = kernel_path()
        self._torque = implementation(rotational_hlcmp_torque, path)
        self._rates = implementation(hlcmp_rates, path)

    @property
    def theta_size(self) -> int:
        """9 N: θ_kr, θ_dr, θ_vr, each (3, N) row-major."""
        return 9 * self.n_basis

    def command(
        self, motion: np.ndarray, torque_nominal: np.ndarray, phase: float, theta: np.ndarray
    ) -> LawOutput:
        """tau_c, the series and θ_r' at this instant.

        Parameters
        ----------
        motion : (24,) array
            From `rotational_motion`.
        torque_nominal : (3,) array
            tau_0 [N m], world.
        phase : float
            s [-].
        theta : (9 N,) array
            θ_kr, θ_dr, θ_vr flattened.

        Returns
        -------
        LawOutput
            force: tau_c [N m], world; logs by `log_fields` (tool frame); rates θ_r'
            [per second], flattened as θ, when first read.
        """
        gains = self.gains
        out = self._torque(
            motion, torque_nominal, gains.gain_l, phase, theta, self.centers, self.widths
        )
        logs = dict(
            rotational_stiffness=out[3:6],
            rotational_damping=out[6:9],
            rotational_feedforward=out[9:12],
            impedance_torque=out[12:15],
            rotational_sliding_error=out[15:18],
        )

        def rates() -> np.ndarray:
            return self._rates(motion[:15], out[18:], gains.q_k, gains.q_d, gains.q_v)

        return LawOutput(out[:3], logs, rates)


class RotationalImpedance:
    """A constant rotational impedance u_r = K_r e_r + D_r omega_e with diagonal K_r
    [N m/rad], D_r [N m s/rad] per tool axis, v_r = 0, and its pi_r [1/s] and L_r
    [N m s/rad]: the rotational half of the constant 6-D impedance baselines
    (`rotational_impedance_torque`, compiled or numpy as `core.kernels.kernel_path` says
    when it is made).

    Parameters
    ----------
    stiffness, damping : (3,) arrays
        Diagonals of K_r and D_r, tool frame.
    pi : float
        pi_r.
    gain_l : (3,) array
        Diagonal of L_r.
    """

    learns = False
    log_fields: dict[str, str] = {}
    theta_size = 0

    def __init__(self, stiffness: np.ndarray, damping: np.ndarray, pi: float, gain_l):
        self.stiffness, self.damping = np.asarray(stiffness, float), np.asarray(damping, float)
        self.gains = HlcmpGains(
            np.zeros(3), np.zeros(3), np.zeros(3), float(pi), np.asarray(gain_l, float)
        )
        self._torque = implementation(rotational_impedance_torque, kernel_path())

    def command(
        self, motion: np.ndarray, torque_nominal: np.ndarray, phase: float, theta: np.ndarray
    ) -> LawOutput:
        """tau_c with u_r = K_r e_r + D_r omega_e and v_r = 0; no series and no rates.

        Parameters
        ----------
        motion : (24,) array
            From `rotational_motion`.
        torque_nominal : (3,) array
            tau_0 [N m], world.
        phase : float
            Unused (the impedance is constant).
        theta : (0,) array
            Unused.

        Returns
        -------
        LawOutput
            force: tau_c [N m], world; no logs, no rates.
        """
        torque = self._torque(
            motion, torque_nominal, self.gains.gain_l, self.stiffness, self.damping
        )
        return LawOutput(torque, {})


class PoseLaw:
    """A 6-D operational-space law made of a translational law of `core.laws` (M = 3,
    unchanged) and a rotational part, on one phase basis: the wrench [tau_c; f_c] of the
    module's equations, by linearity split in two so that each half is its own law.

    The 6-D nominal wrench Lambda V_e' + C_x V_e + p splits by rows (`pose_nominal_split`):
    the translational law is given exactly what the 3-D world gives it, with the
    translational blocks Lambda_vv and C_x V_e's rows, and the coupling Lambda_vw
    omega_ref' added to its gravity p_v; so its errors, profiles, u, v, θ' are its own
    computations, and with no coupling (Lambda_vw = 0, C_vw = 0) its force is the 3-D law's
    to the bit. The rotational rows give tau_0 = Lambda_ww omega_ref' + Lambda_wv x_e'' +
    (C_x V_e)_w + p_w, and the rotational part the command (`rotational_torque`).

    The arithmetic between the one Coriolis product (Drake's, on the fast path) is a few
    compiled calls (`pose_motion`, `pose_nominal_split`, each half's own), or numpy, as
    `core.kernels.kernel_path` says when the law and its halves are made.

    Parameters
    ----------
    translational : HlcmpLaw, HlcmpForgettingLaw or ConstantImpedanceLaw
        A `core.laws` law with `command_from_motion`, M = 3; its `gains.pi` or `pi` is the
        translational slope of Eq. 29.
    rotational : RotationalHlcmp or RotationalImpedance
    """

    reads_external_force = False
    n_axes = 6

    def __init__(self, translational, rotational):
        assert not translational.reads_external_force and translational.n_axes == 3
        self.translational, self.rotational = translational, rotational
        self.learns = translational.learns or rotational.theta_size > 0
        self.log_fields = {**translational.log_fields, **rotational.log_fields}
        gains = getattr(translational, "gains", None)
        self.pi = gains.pi if gains is not None else translational.pi
        path = kernel_path()
        self._motion = implementation(pose_motion, path)
        self._split = implementation(pose_nominal_split, path)

    @property
    def theta_size(self) -> int:
        """The translational law's θ, then the rotational part's."""
        return self.translational.theta_size + self.rotational.theta_size

    def unflatten(self, theta: np.ndarray) -> tuple[np.ndarray, ...]:
        """The translational law's parts, then (θ_kr, θ_dr, θ_vr) for a learning rotation.

        Parameters
        ----------
        theta : (theta_size,) array
        """
        split = self.translational.theta_size
        rotational = np.asarray(theta, float)[split:]
        rotational_parts = tuple(rotational.reshape(3, 3, -1)) if len(rotational) else ()
        return (*self.translational.unflatten(np.asarray(theta, float)[:split]), *rotational_parts)

    def command(self, now: PoseInstant, theta: np.ndarray | None) -> LawOutput:
        """The wrench, both halves' series and θ' at this instant.

        Parameters
        ----------
        now : PoseInstant
        theta : (theta_size,) array, or None for a law with no θ

        Returns
        -------
        LawOutput
            force: [tau_c; f_c] [N m; N], world (Drake's order); logs by `log_fields`
            (translational world frame, rotational tool frame); rates θ' flattened as θ,
            or None when neither half learns.
        """
        theta = np.zeros(0) if theta is None else np.asarray(theta, float)
        split = self.translational.theta_size
        motion = self._motion(
            now.x,
            now.xdot,
            now.xd,
            now.xd_dot,
            now.xd_ddot,
            now.orientation,
            now.omega,
            now.desired_orientation,
            now.omega_d,
            now.omega_d_dot,
            self.pi,
            self.rotational.gains.pi,
        )
        # [e, e', eps, x_e', x_e''] (15), then [e_r, omega_e, eps_r, omega_ref, omega_ref', R]
        translational_motion, rotational_motion = motion[:15], motion[15:]
        coriolis_term = spatial_coriolis_term(now.coriolis, motion[24:27], motion[9:12])
        inertia, gravity, torque_nominal = self._split(
            motion, now.inertia, coriolis_term, now.gravity
        )
        translational = self.translational.command_from_motion(
            translational_motion, inertia, coriolis_term[3:], gravity, now.phase, theta[:split]
        )
        rotational = self.rotational.command(
            rotational_motion, torque_nominal, now.phase, theta[split:]
        )
        wrench = np.concatenate((rotational.force, translational.force))
        logs = {**translational.logs, **rotational.logs}
        translational_rates, rotational_rates = translational.rates_of, rotational.rates_of
        if translational_rates is None and rotational_rates is None:
            return LawOutput(wrench, logs)

        def rates() -> np.ndarray:
            return np.concatenate(
                [
                    translational_rates() if translational_rates is not None else np.zeros(0),
                    rotational_rates() if rotational_rates is not None else np.zeros(0),
                ]
            )

        return LawOutput(wrench, logs, rates)


@dataclass(frozen=True)
class PoseImpedance:
    """A constant 6-D impedance: diagonals of the translational K [N/m] and D [N s/m]
    (world axes) and of the rotational K_r [N m/rad] and D_r [N m s/rad] (tool axes), each
    (3,)."""

    stiffness: np.ndarray
    damping: np.ndarray
    rotational_stiffness: np.ndarray
    rotational_damping: np.ndarray


def constant_pose_impedance(
    impedance: PoseImpedance, pi: float, gain_l: np.ndarray, pi_r: float, gain_l_r: np.ndarray
) -> PoseLaw:
    """The constant 6-D impedance baseline: the 3-D `laws.ConstantImpedanceLaw` and a
    `RotationalImpedance` in one `PoseLaw`, i.e. the 6-D Hl-CMP's command with fixed
    diagonal K, D, K_r, D_r and v = v_r = 0, so that a comparison differs only in whether
    the impedance is learned:

    .. math:: F = F_0 - [R (L_r \\varepsilon_r + K_r e_r + D_r \\omega_e);\\;
              L \\varepsilon + K e + D \\dot e]

    Parameters
    ----------
    impedance : PoseImpedance
    pi, pi_r : float
        Translational and rotational sliding-surface slopes [1/s].
    gain_l, gain_l_r : (3,) arrays
        Diagonals of L [N s/m] and L_r [N m s/rad].

    Returns
    -------
    PoseLaw
        With no θ (theta_size 0).
    """
    return PoseLaw(
        ConstantImpedanceLaw(impedance.stiffness, impedance.damping, pi, gain_l),
        RotationalImpedance(
            impedance.rotational_stiffness, impedance.rotational_damping, pi_r, gain_l_r
        ),
    )
