"""Task-space control laws (paper Eqs. 3-5, 29, 33-34), pure numpy.

Vectors are (M,) task-space quantities; matrices (M, M). The dynamics terms M, C, G
come from Drake (see `systems.task_space.TaskSpaceDynamics`), never from here. Every
function is `jitable`: numba compiles it into the tick's kernels (`core.kernels`).
"""

import numpy as np

from hlcmp_drake.core.kernels import jitable
from hlcmp_drake.core.small_linalg import matmul


@jitable
def tracking_errors(
    x: np.ndarray, xdot: np.ndarray, xd: np.ndarray, xd_dot: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 5: e = x - x_d, e' = x' - x_d'.

    Parameters
    ----------
    x, xdot : (M,) arrays
        Measured task-space position [m] and velocity [m/s].
    xd, xd_dot : (M,) arrays
        Desired position [m] and velocity [m/s].

    Returns
    -------
    e, edot : (M,) arrays
        Position error [m] and velocity error [m/s].
    """
    return np.asarray(x) - xd, np.asarray(xdot) - xd_dot


@jitable
def impedance_force(
    k_s: np.ndarray, k_d: np.ndarray, e: np.ndarray, edot: np.ndarray
) -> np.ndarray:
    """Eq. 4: u = K_s e + K_d e' with diagonal K_s, K_d given by their diagonals (M,).

    Parameters
    ----------
    k_s, k_d : (M,) arrays
        Diagonals of the stiffness K_s [N/m] and damping K_d [N s/m].
    e, edot : (M,) arrays
        Position error [m] and velocity error [m/s].

    Returns
    -------
    u : (M,) array
        Impedance force [N].
    """
    return k_s * e + k_d * edot


@jitable
def sliding_error(e: np.ndarray, edot: np.ndarray, pi: float) -> np.ndarray:
    """Eq. 29: eps = e' + pi e, pi > 0.

    Parameters
    ----------
    e, edot : (M,) arrays
        Position error [m] and velocity error [m/s].
    pi : float
        Slope of the sliding surface [1/s], > 0.

    Returns
    -------
    eps : (M,) array
        Sliding error [m/s].
    """
    return edot + pi * e


@jitable
def reference_motion(
    xd_dot: np.ndarray, xd_ddot: np.ndarray, e: np.ndarray, edot: np.ndarray, pi: float
) -> tuple[np.ndarray, np.ndarray]:
    """The auxiliary reference of Eq. 34: x_e' = x_d' - pi e and its derivative
    x_e'' = x_d'' - pi e' (so that eps = x' - x_e').

    Parameters
    ----------
    xd_dot, xd_ddot : (M,) arrays
        Desired velocity [m/s] and acceleration [m/s^2].
    e, edot, pi
        As for `sliding_error`.

    Returns
    -------
    xe_dot, xe_ddot : (M,) arrays
        Reference velocity [m/s] and acceleration [m/s^2].
    """
    return xd_dot - pi * e, xd_ddot - pi * edot


@jitable
def nominal_force(
    inertia: np.ndarray,
    coriolis_term: np.ndarray,
    gravity: np.ndarray,
    xe_ddot: np.ndarray,
    gain_l: np.ndarray,
    eps: np.ndarray,
) -> np.ndarray:
    """Eq. 34: f_0 = M x_e'' + C x_e' + G - L eps, with L given by its diagonal (M,).

    C enters only as its product with x_e', which the fast path has Drake compute without
    forming C (`systems.task_space.CoriolisProduct`).

    Parameters
    ----------
    inertia, gravity : (M, M), (M,) arrays
        Task-space M [kg] and G [N] of Eq. 2, from Drake.
    coriolis_term : (M,) array
        C x_e' [N], C [kg/s] of Eq. 2 times the reference velocity of `reference_motion`.
    xe_ddot : (M,) array
        Reference acceleration [m/s^2] (see `reference_motion`).
    gain_l : (M,) array
        Diagonal of the feedback gain L [N s/m].
    eps : (M,) array
        Sliding error [m/s].

    Returns
    -------
    f0 : (M,) array
        Nominal force [N].
    """
    return matmul(inertia, xe_ddot) + coriolis_term + gravity - gain_l * eps


@jitable
def commanded_force(f0: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Eq. 33: f_c = f_0 - u - v (Eq. 3 is the special case f_0 = 0).

    Parameters
    ----------
    f0 : (M,) array
        Nominal force [N].
    u : (M,) array
        Impedance force [N].
    v : (M,) array
        Feed-forward force [N].

    Returns
    -------
    fc : (M,) array
        Commanded task-space force [N].
    """
    return f0 - u - v


@jitable
def sliding_motion(
    x: np.ndarray,
    xdot: np.ndarray,
    xd: np.ndarray,
    xd_dot: np.ndarray,
    xd_ddot: np.ndarray,
    pi: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What every task-space impedance law here computes before its Coriolis term: the
    tracking errors (Eq. 5), the sliding error (Eq. 29) and the reference motion of Eq. 34.

    Parameters
    ----------
    x, xdot : (M,) arrays
        Measured task-space position [m] and velocity [m/s].
    xd, xd_dot, xd_ddot : (M,) arrays
        Desired position [m], velocity [m/s] and acceleration [m/s^2].
    pi : float
        Slope of the sliding surface [1/s], > 0 (Eq. 29).

    Returns
    -------
    e, edot, eps, xe_dot, xe_ddot : (M,) arrays
        Position error [m], velocity error [m/s], sliding error [m/s], and the reference
        velocity [m/s] (the vector C multiplies in Eq. 34) and acceleration [m/s^2].
    """
    e, edot = tracking_errors(x, xdot, xd, xd_dot)
    eps = sliding_error(e, edot, pi)
    xe_dot, xe_ddot = reference_motion(xd_dot, xd_ddot, e, edot, pi)
    return e, edot, eps, xe_dot, xe_ddot
