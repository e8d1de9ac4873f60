"""hlcmp_drake.core.control_law: the control law (Eqs. 4, 5, 29, 33, 34), by hand."""

import numpy as np

from hlcmp_drake.core.control_law import (
    commanded_force,
    impedance_force,
    nominal_force,
    reference_motion,
    sliding_error,
    tracking_errors,
)


def test_commanded_force_hand_computed():
    # 1 axis, M = 5, C = 0.5, G = 2, x_d' = 0.1, x_d'' = 0, e = 0.05, e' = -0.02, pi = 4, L = 3
    e, edot = tracking_errors(np.array([0.15]), np.array([0.08]), np.array([0.1]), np.array([0.1]))
    np.testing.assert_allclose([e[0], edot[0]], [0.05, -0.02])
    eps = sliding_error(e, edot, 4.0)  # 0.18
    xe_dot, xe_ddot = reference_motion(np.array([0.1]), np.array([0.0]), e, edot, 4.0)
    np.testing.assert_allclose([xe_dot[0], xe_ddot[0]], [0.1 - 0.2, 0.08])
    f0 = nominal_force(
        np.array([[5.0]]),
        np.array([[0.5]]) @ xe_dot,
        np.array([2.0]),
        xe_ddot,
        np.array([3.0]),
        eps,
    )
    np.testing.assert_allclose(f0, [5 * 0.08 + 0.5 * -0.1 + 2.0 - 3 * 0.18])
    u = impedance_force(np.array([100.0]), np.array([10.0]), e, edot)
    np.testing.assert_allclose(u, [100 * 0.05 + 10 * -0.02])
    np.testing.assert_allclose(commanded_force(f0, u, np.array([1.0])), f0 - u - 1.0)
