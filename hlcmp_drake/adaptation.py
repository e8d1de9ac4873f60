"""The Hl-CMP compliant profiles and the biomimetic adaptation law (paper Eqs. 14, 31).

Pure numpy. theta_k, theta_d, theta_v are (M, N) arrays: one row of N basis weights per
Cartesian axis; g is the (N,) normalized basis g(s) of Eq. 16 at the current phase.
"""

import numpy as np


def compliant_profiles(theta_k, theta_d, theta_v, g):
    """Eq. 14: K_s,m = theta_k,m . g(s), K_d,m = theta_d,m . g(s), v_m = theta_v,m . g(s).

    Returns the diagonals of K_s and K_d and the feed-forward force v, each (M,).
    """
    return theta_k @ g, theta_d @ g, theta_v @ g


def adaptation_rates(eps, e, edot, g, q_k, q_d, q_v):
    """Eq. 31, per axis m:

        theta_k,m' = Q_k,m eps_m e_m g(s)
        theta_d,m' = Q_d,m eps_m e'_m g(s)
        theta_v,m' = Q_v,m eps_m g(s)

    eps, e, edot, q_k, q_d, q_v: (M,); g: (N,). Returns three (M, N) arrays.
    Q_v = 0 is allowed (the feed-forward force then stays at its initial profile).
    """
    eps = np.asarray(eps, dtype=float)
    return (np.outer(q_k * eps * e, g), np.outer(q_d * eps * edot, g), np.outer(q_v * eps, g))
