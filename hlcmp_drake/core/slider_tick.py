"""The slider's tick in one compiled call per law: the task-space motion of a robot of
prismatic joints whose task axes are its joints (x = x(0) + J q, x' = J v, with Λ, C_x = 0
and G_x constant: `systems.task_space.PrismaticTaskModel`), the law, and the saturated
joint force. Each composes the `jitable` functions that hold the equations (`laws`,
`operational_space`); none writes an equation of its own. `systems.slider_tick` calls them;
`systems.control_loop.ControlTick` evaluates the same equations through the laws' shared
interface.

Each takes what changes every tick first (the state, the reference, θ, the measured force)
and the constants after them, and returns one array: [the joint force (nv), the number of
saturated joints, x (M), then the law's own output].
"""

from __future__ import annotations

import numpy as np

from hlcmp_drake.core.kernels import jitable
from hlcmp_drake.core.laws import (
    hlcmp_command,
    impedance_command,
    impedance_motion,
    variable_impedance_command,
)
from hlcmp_drake.core.operational_space import task_joint_torque


@jitable
def _slider_motion(
    state: np.ndarray, position_at_zero: np.ndarray, jacobian: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """x = x(0) + J q [m] and x' = J v [m/s] of a plant state [q, v]."""
    nq = jacobian.shape[1]
    return position_at_zero + jacobian @ state[:nq], jacobian @ state[nq:]


@jitable
def _slider_output(
    jacobian: np.ndarray, force: np.ndarray, limits: np.ndarray, x: np.ndarray, law: np.ndarray
) -> np.ndarray:
    """[the saturated J^T f (`task_joint_torque`, nothing below the task), the number of
    saturated joints, x, the law's output]."""
    torque, saturated = task_joint_torque(jacobian, force, np.zeros(jacobian.shape[1]), limits)
    return np.concatenate((torque, np.array([float(saturated)]), x, law))


@jitable
def hlcmp_slider_tick(
    state: np.ndarray,
    xd: np.ndarray,
    xd_dot: np.ndarray,
    xd_ddot: np.ndarray,
    phase: float,
    theta: np.ndarray,
    position_at_zero: np.ndarray,
    jacobian: np.ndarray,
    inertia: np.ndarray,
    coriolis: np.ndarray,
    gravity: np.ndarray,
    pi: float,
    gain_l: np.ndarray,
    centers: np.ndarray,
    widths: np.ndarray,
    q_k: np.ndarray,
    q_d: np.ndarray,
    q_v: np.ndarray,
    limits: np.ndarray,
) -> np.ndarray:
    """The Hl-CMP's slider tick: `hlcmp_command` at the slider's motion, then the joint
    force.

    Parameters
    ----------
    state : (nq + nv,) array
        [q, v] [m], [m/s].
    xd, xd_dot, xd_ddot : (M,) arrays
        The reference.
    phase : float
        s [-].
    theta : (3 M N,) array
        As for `hlcmp_command`.
    position_at_zero, jacobian, inertia, coriolis, gravity
        x(0) (M,), J (M, nv), Λ, C_x (M, M) and G_x (M,) (`PrismaticTaskModel.constants`).
    pi, gain_l, centers, widths, q_k, q_d, q_v
        As for `hlcmp_command`.
    limits : (nv,) array
        The effort limits [N].

    Returns
    -------
    (nv + 1 + M + 6 M + 3 M N,) array
        The joint force [N], the number of saturated joints, x [m], then `hlcmp_command`'s
        output (f_c, K_s, K_d, v, u, ε, θ').
    """
    m = xd.shape[0]
    x, xdot = _slider_motion(state, position_at_zero, jacobian)
    out = hlcmp_command(
        x,
        xdot,
        xd,
        xd_dot,
        xd_ddot,
        phase,
        inertia,
        coriolis,
        gravity,
        pi,
        gain_l,
        theta,
        centers,
        widths,
        q_k,
        q_d,
        q_v,
    )
    return _slider_output(jacobian, out[:m], limits, x, out)


@jitable
def impedance_slider_tick(
    state: np.ndarray,
    xd: np.ndarray,
    xd_dot: np.ndarray,
    xd_ddot: np.ndarray,
    position_at_zero: np.ndarray,
    jacobian: np.ndarray,
    inertia: np.ndarray,
    coriolis: np.ndarray,
    gravity: np.ndarray,
    pi: float,
    gain_l: np.ndarray,
    stiffness: np.ndarray,
    damping: np.ndarray,
    limits: np.ndarray,
) -> np.ndarray:
    """The constant impedance's slider tick: `impedance_motion`, `impedance_command` with
    C_x x_e', then the joint force.

    Parameters
    ----------
    state, xd, xd_dot, xd_ddot, position_at_zero, jacobian, inertia, coriolis, gravity
        As for `hlcmp_slider_tick`.
    pi, gain_l, stiffness, damping
        As for `impedance_motion` and `impedance_command`.
    limits : (nv,) array
        The effort limits [N].

    Returns
    -------
    (nv + 1 + M + M,) array
        The joint force [N], the number of saturated joints, x [m], f_c [N].
    """
    m = xd.shape[0]
    x, xdot = _slider_motion(state, position_at_zero, jacobian)
    motion = impedance_motion(x, xdot, xd, xd_dot, xd_ddot, pi)
    force = impedance_command(
        motion, inertia, coriolis @ motion[3 * m : 4 * m], gravity, gain_l, stiffness, damping
    )
    return _slider_output(jacobian, force, limits, x, force)


@jitable
def variable_impedance_slider_tick(
    state: np.ndarray,
    xd: np.ndarray,
    xd_dot: np.ndarray,
    xd_ddot: np.ndarray,
    theta: np.ndarray,
    desired_force: np.ndarray,
    external_force: np.ndarray,
    position_at_zero: np.ndarray,
    jacobian: np.ndarray,
    inertia: np.ndarray,
    coriolis: np.ndarray,
    gravity: np.ndarray,
    mass: np.ndarray,
    damping: np.ndarray,
    free_stiffness: np.ndarray,
    kp: np.ndarray,
    kv: np.ndarray,
    sigma: float,
    sample_period: float,
    limits: np.ndarray,
) -> np.ndarray:
    """The variable impedance's slider tick: `variable_impedance_command` at the slider's
    motion (C_x x'), then the joint force.

    Parameters
    ----------
    state, xd, xd_dot, xd_ddot
        As for `hlcmp_slider_tick`.
    theta, desired_force, external_force
        As for `variable_impedance_command`.
    position_at_zero, jacobian, inertia, coriolis, gravity
        As for `hlcmp_slider_tick`.
    mass, damping, free_stiffness, kp, kv, sigma, sample_period
        As for `variable_impedance_command`.
    limits : (nv,) array
        The effort limits [N].

    Returns
    -------
    (nv + 1 + M + 4 M,) array
        The joint force [N], the number of saturated joints, x [m], then
        `variable_impedance_command`'s output (the force, θ's rates).
    """
    m = xd.shape[0]
    x, xdot = _slider_motion(state, position_at_zero, jacobian)
    out = variable_impedance_command(
        theta,
        xd,
        xd_dot,
        xd_ddot,
        desired_force,
        external_force,
        x,
        xdot,
        inertia,
        coriolis @ xdot,
        gravity,
        mass,
        damping,
        free_stiffness,
        kp,
        kv,
        sigma,
        sample_period,
    )
    return _slider_output(jacobian, out[:m], limits, x, out)
