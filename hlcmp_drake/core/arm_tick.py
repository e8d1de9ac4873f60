"""The arm's translational tick in two compiled calls, around the two Drake evaluations
of the Coriolis product: `arm_tick_start` before them, a law's finish after
(`hlcmp_arm_tick_finish`, `impedance_arm_tick_finish`). Each composes the `jitable`
functions that hold the equations (`operational_space`, `laws`); none writes an equation
of its own. `systems.arm_tick.FusedArmTick` calls them; `systems.control_loop.ControlTick`
evaluates the same equations through the laws' shared interface with about six compiled
calls and the Python between them, which in a running insertion cost a third of its tick
(docs/performance.md, "Where the floor is").

Every array a call hands back to Python costs, so `arm_tick_start` returns one array,
the layout of `start_layout`, which the finish takes back whole.
"""

from __future__ import annotations

import numpy as np

from hlcmp_drake.core.kernels import jitable
from hlcmp_drake.core.laws import hlcmp_force, hlcmp_rates, impedance_command, impedance_motion
from hlcmp_drake.core.operational_space import (
    below_task_torque,
    operational_space_terms,
    polarized_coriolis,
    task_joint_torque,
)
from hlcmp_drake.core.small_linalg import matmul


@jitable
def start_layout(nv: int, m: int) -> np.ndarray:
    """The offsets of `arm_tick_start`'s parts: u (nv), x' (M), Λ (M M), J̄ (nv M), G_x (M),
    N^T (nv nv), the motion (5 M), and the end.

    Parameters
    ----------
    nv, m : int
        The arm's velocities and the task axes.

    Returns
    -------
    (8,) int array
    """
    sizes = np.array([0, nv, m, m * m, nv * m, m, nv * nv, 5 * m])
    return np.cumsum(sizes)


@jitable
def arm_tick_start(
    mass: np.ndarray,
    spatial_jacobian: np.ndarray,
    first_row: int,
    joint_gravity: np.ndarray,
    position: np.ndarray,
    velocities: np.ndarray,
    xd: np.ndarray,
    xd_dot: np.ndarray,
    xd_ddot: np.ndarray,
    pi: float,
) -> np.ndarray:
    """What an impedance law's tick computes before C_x x_e': the operational-space terms
    (`operational_space_terms`), x' = J v, the sliding motion (`impedance_motion`) and
    u = J̄ x_e', the velocity offset of the polarization (`polarized_coriolis`).

    Parameters
    ----------
    mass : (nv, nv) array
        M(q).
    spatial_jacobian : (6, nv) array
        The task point's spatial-velocity Jacobian, world (angular rows, then translational).
    first_row : int
        The row of its first task axis; the M axes are consecutive.
    joint_gravity : (nv,) array
        G(q) [N m].
    position : (M,) array
        x [m].
    velocities : (nv,) array
        v [rad/s].
    xd, xd_dot, xd_ddot : (M,) arrays
        The reference [m], [m/s], [m/s^2].
    pi : float
        Slope of the sliding surface [1/s].

    Returns
    -------
    array
        The parts of `start_layout`, one after the other (matrices row-major).
    """
    m = position.shape[0]
    jacobian = np.ascontiguousarray(spatial_jacobian[first_row : first_row + m])
    inertia, jbar, gravity, null_space = operational_space_terms(mass, jacobian, joint_gravity)
    xdot = matmul(jacobian, velocities)
    motion = impedance_motion(position, xdot, xd, xd_dot, xd_ddot, pi)
    return np.concatenate(
        (
            matmul(jbar, motion[3 * m : 4 * m]),
            xdot,
            inertia.ravel(),
            jbar.ravel(),
            gravity,
            null_space.ravel(),
            motion,
        )
    )


@jitable
def _after_biases(
    start: np.ndarray,
    bias_plus: np.ndarray,
    bias_minus: np.ndarray,
    accel_plus: np.ndarray,
    accel_minus: np.ndarray,
    nv: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Λ, G_x, N^T and the motion out of `arm_tick_start`'s array, and C_x x_e' from Drake's
    two evaluations (`polarized_coriolis`)."""
    m = accel_plus.shape[0]
    at = start_layout(nv, m)
    inertia = start[at[2] : at[3]].copy().reshape(m, m)
    jbar = start[at[3] : at[4]].copy().reshape(nv, m)
    coriolis_term = polarized_coriolis(
        jbar, inertia, bias_plus, bias_minus, accel_plus, accel_minus
    )
    return (
        inertia,
        start[at[4] : at[5]].copy(),
        start[at[5] : at[6]].copy().reshape(nv, nv),
        start[at[6] : at[7]].copy(),
        coriolis_term,
    )


@jitable
def _arm_torque(
    force: np.ndarray,
    null_space: np.ndarray,
    spatial_jacobian: np.ndarray,
    first_row: int,
    rotation: np.ndarray,
    positions: np.ndarray,
    velocities: np.ndarray,
    joint_gravity: np.ndarray,
    desired_inverse: np.ndarray,
    nominal_positions: np.ndarray,
    below_gains: np.ndarray,
    limits: np.ndarray,
) -> np.ndarray:
    """[τ (nv), the number of saturated joints]: `task_joint_torque` of f_c over the torque
    below the task (`below_task_torque`; `below_gains` = K_o, D_o, K_p, D_p)."""
    m = force.shape[0]
    below = below_task_torque(
        null_space,
        joint_gravity,
        np.ascontiguousarray(spatial_jacobian[:3]),
        rotation,
        desired_inverse,
        positions,
        velocities,
        nominal_positions,
        below_gains[0],
        below_gains[1],
        below_gains[2],
        below_gains[3],
    )
    jacobian = np.ascontiguousarray(spatial_jacobian[first_row : first_row + m])
    torque, saturated = task_joint_torque(jacobian, force, below, limits)
    return np.concatenate((torque, np.array([float(saturated)])))


@jitable
def hlcmp_arm_tick_finish(
    start: np.ndarray,
    bias_plus: np.ndarray,
    bias_minus: np.ndarray,
    accel_plus: np.ndarray,
    accel_minus: np.ndarray,
    spatial_jacobian: np.ndarray,
    first_row: int,
    rotation: np.ndarray,
    positions: np.ndarray,
    velocities: np.ndarray,
    joint_gravity: np.ndarray,
    phase: float,
    theta: np.ndarray,
    centers: np.ndarray,
    widths: np.ndarray,
    gain_l: np.ndarray,
    q_k: np.ndarray,
    q_d: np.ndarray,
    q_v: np.ndarray,
    desired_inverse: np.ndarray,
    nominal_positions: np.ndarray,
    below_gains: np.ndarray,
    limits: np.ndarray,
) -> np.ndarray:
    """The Hl-CMP's tick after Drake's two evaluations at v ± u: C_x x_e'
    (`polarized_coriolis`), f_c and its series (`hlcmp_force`), θ' of Eq. 31
    (`hlcmp_rates`), and the joint torque (`task_joint_torque` over `below_task_torque`).

    Parameters
    ----------
    start : array
        From `arm_tick_start`.
    bias_plus, bias_minus : (nv,) arrays
        C(q, v ± u)(v ± u) [N m].
    accel_plus, accel_minus : (M,) arrays
        J'(v ± u) (v ± u), the task rows [m/s^2].
    spatial_jacobian, first_row : as for `arm_tick_start`
    rotation : (3, 3) array
        The tool's orientation, world.
    positions, velocities, joint_gravity : (nv,) arrays
        q [rad], v [rad/s], G(q) [N m].
    phase : float
        s [-].
    theta, centers, widths, gain_l, q_k, q_d, q_v
        As for `hlcmp_force` and `hlcmp_rates`.
    desired_inverse, nominal_positions
        As for `below_task_torque`.
    below_gains : (4,) array
        K_o, D_o, K_p, D_p of `below_task_torque`.
    limits : (nv,) array
        The effort limits [N m].

    Returns
    -------
    (nv + 1 + 6 M + 3 M N,) array
        τ [N m], the number of saturated joints, `hlcmp_force`'s f_c, K_s, K_d, v, u, ε,
        then θ'.
    """
    m = accel_plus.shape[0]
    inertia, gravity, null_space, motion, coriolis_term = _after_biases(
        start, bias_plus, bias_minus, accel_plus, accel_minus, positions.shape[0]
    )
    out = hlcmp_force(
        motion, inertia, coriolis_term, gravity, gain_l, phase, theta, centers, widths
    )
    torque = _arm_torque(
        out[:m],
        null_space,
        spatial_jacobian,
        first_row,
        rotation,
        positions,
        velocities,
        joint_gravity,
        desired_inverse,
        nominal_positions,
        below_gains,
        limits,
    )
    rates = hlcmp_rates(motion, out[6 * m :], q_k, q_d, q_v)
    return np.concatenate((torque, out[: 6 * m], rates))


@jitable
def impedance_arm_tick_finish(
    start: np.ndarray,
    bias_plus: np.ndarray,
    bias_minus: np.ndarray,
    accel_plus: np.ndarray,
    accel_minus: np.ndarray,
    spatial_jacobian: np.ndarray,
    first_row: int,
    rotation: np.ndarray,
    positions: np.ndarray,
    velocities: np.ndarray,
    joint_gravity: np.ndarray,
    gain_l: np.ndarray,
    stiffness: np.ndarray,
    damping: np.ndarray,
    desired_inverse: np.ndarray,
    nominal_positions: np.ndarray,
    below_gains: np.ndarray,
    limits: np.ndarray,
) -> np.ndarray:
    """The constant impedance's tick after Drake's two evaluations at v ± u: C_x x_e'
    (`polarized_coriolis`), f_c (`impedance_command`) and the joint torque.

    Parameters
    ----------
    start, bias_plus, bias_minus, accel_plus, accel_minus, spatial_jacobian, first_row,
    rotation, positions, velocities, joint_gravity
        As for `hlcmp_arm_tick_finish`.
    gain_l, stiffness, damping : (M,) arrays
        As for `impedance_command`.
    desired_inverse, nominal_positions, below_gains, limits
        As for `hlcmp_arm_tick_finish`.

    Returns
    -------
    (nv + 1 + M,) array
        τ [N m], the number of saturated joints, f_c [N].
    """
    inertia, gravity, null_space, motion, coriolis_term = _after_biases(
        start, bias_plus, bias_minus, accel_plus, accel_minus, positions.shape[0]
    )
    force = impedance_command(motion, inertia, coriolis_term, gravity, gain_l, stiffness, damping)
    torque = _arm_torque(
        force,
        null_space,
        spatial_jacobian,
        first_row,
        rotation,
        positions,
        velocities,
        joint_gravity,
        desired_inverse,
        nominal_positions,
        below_gains,
        limits,
    )
    return np.concatenate((torque, force))
