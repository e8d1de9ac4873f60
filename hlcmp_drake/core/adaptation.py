"""The Hl-CMP compliant profiles and the biomimetic adaptation law (paper Eqs. 14, 31).

Pure numpy, `jitable` (`core.kernels`). theta_k, theta_d, theta_v are (M, N) arrays: one row
of N basis weights per Cartesian axis; g is the (N,) normalized basis g(s) of Eq. 16 at the
current phase.
"""

import numpy as np

from hlcmp_drake.core.kernels import jitable
from hlcmp_drake.core.small_linalg import matmul


@jitable
def compliant_profiles(
    theta_k: np.ndarray, theta_d: np.ndarray, theta_v: np.ndarray, g: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eq. 14: K_s,m = theta_k,m . g(s), K_d,m = theta_d,m . g(s), v_m = theta_v,m . g(s).

    Parameters
    ----------
    theta_k, theta_d, theta_v : (M, N) arrays
        Basis weights of the stiffness [N/m], damping [N s/m] and feed-forward force [N]
        profiles, one row per axis.
    g : (N,) array
        Normalized basis g(s) at the current phase [-].

    Returns
    -------
    k_s, k_d, v : (M,) arrays
        Diagonals of K_s [N/m] and K_d [N s/m], and the feed-forward force v [N].
    """
    return matmul(theta_k, g), matmul(theta_d, g), matmul(theta_v, g)


@jitable
def adaptation_rates(
    eps: np.ndarray,
    e: np.ndarray,
    edot: np.ndarray,
    g: np.ndarray,
    q_k: np.ndarray,
    q_d: np.ndarray,
    q_v: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eq. 31, per axis m:

        theta_k,m' = Q_k,m eps_m e_m g(s)
        theta_d,m' = Q_d,m eps_m e'_m g(s)
        theta_v,m' = Q_v,m eps_m g(s)

    Q_v = 0 is allowed (the feed-forward force then stays at its initial profile).

    Parameters
    ----------
    eps : (M,) array
        Sliding error [m/s].
    e, edot : (M,) arrays
        Position error [m] and velocity error [m/s].
    g : (N,) array
        Normalized basis g(s) at the current phase [-].
    q_k, q_d, q_v : (M,) arrays
        Per-axis learning rates Q_k, Q_d, Q_v (>= 0).

    Returns
    -------
    theta_k_dot, theta_d_dot, theta_v_dot : (M, N) arrays
        Time derivatives of theta_k [N/(m s)], theta_d [N/m] and theta_v [N/s].
    """
    eps = np.asarray(eps, dtype=np.float64)
    return (np.outer(q_k * eps * e, g), np.outer(q_d * eps * edot, g), np.outer(q_v * eps, g))


@jitable
def forgetting_rates(rates: np.ndarray, theta: np.ndarray, gamma: float) -> np.ndarray:
    """The adaptation law with a forgetting factor (Yang et al. 2011, the -γK term of their
    stiffness adaptation): θ' = (Eq. 31) - γ θ.

    Without it a weight only falls where the Eq. 31 increment is negative (ε e < 0 for the
    stiffness); with γ > 0 every weight decays towards zero at the rate γ wherever the
    error, and so the Eq. 31 increment, vanishes. γ = 0 is the paper's law.

    Parameters
    ----------
    rates : (P,) array
        The flattened Eq. 31 rates of θ = [θ_k, θ_d, θ_v].
    theta : (P,) array
        The current weights, flattened the same way.
    gamma : float
        The forgetting factor γ >= 0 [1/s].

    Returns
    -------
    (P,) array
        θ' [per second].
    """
    return rates - gamma * np.asarray(theta, dtype=np.float64)
