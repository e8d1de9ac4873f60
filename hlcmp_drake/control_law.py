"""Task-space control laws (paper Eqs. 3-5, 29, 33-34), pure numpy.

Vectors are (M,) task-space quantities; matrices (M, M). The dynamics terms M, C, G
come from Drake (see `systems.task_space.TaskSpaceDynamics`), never from here.
"""

import numpy as np


def tracking_errors(x, xdot, xd, xd_dot):
    """Eq. 5: e = x - x_d, e' = x' - x_d'."""
    return np.asarray(x) - xd, np.asarray(xdot) - xd_dot


def impedance_force(k_s, k_d, e, edot):
    """Eq. 4: u = K_s e + K_d e' with diagonal K_s, K_d given by their diagonals (M,)."""
    return k_s * e + k_d * edot


def sliding_error(e, edot, pi):
    """Eq. 29: eps = e' + pi e, pi > 0."""
    return edot + pi * e


def reference_motion(xd_dot, xd_ddot, e, edot, pi):
    """The auxiliary reference of Eq. 34: x_e' = x_d' - pi e and its derivative
    x_e'' = x_d'' - pi e' (so that eps = x' - x_e')."""
    return xd_dot - pi * e, xd_ddot - pi * edot


def nominal_force(inertia, coriolis, gravity, xe_dot, xe_ddot, gain_l, eps):
    """Eq. 34: f_0 = M x_e'' + C x_e' + G - L eps, with L given by its diagonal (M,)."""
    return inertia @ xe_ddot + coriolis @ xe_dot + gravity - gain_l * eps


def commanded_force(f0, u, v):
    """Eq. 33: f_c = f_0 - u - v (Eq. 3 is the special case f_0 = 0)."""
    return f0 - u - v
