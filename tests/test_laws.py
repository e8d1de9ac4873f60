"""The adaptation law (Eq. 31), profiles (Eq. 14) and control law (Eqs. 4, 5, 29, 33, 34)."""

import numpy as np

from hlcmp_drake.core.adaptation import adaptation_rates, compliant_profiles
from hlcmp_drake.core.control_law import (
    commanded_force,
    impedance_force,
    nominal_force,
    reference_motion,
    sliding_error,
    tracking_errors,
)
from hlcmp_drake.core.duan2018 import duan_adaptation_step, duan_admittance_acceleration


def test_adaptation_rates_hand_computed():
    # Axis 0: e = 0.1, e' = 0.2, pi = 2 -> eps = 0.4; g = [0.25, 0.75]; Q = (3000, 90, 9)
    e, edot = np.array([0.1, -0.05]), np.array([0.2, 0.0])
    eps = sliding_error(e, edot, 2.0)
    np.testing.assert_allclose(eps, [0.4, -0.1])
    g = np.array([0.25, 0.75])
    q = np.array([3000.0, 3000.0]), np.array([90.0, 90.0]), np.array([9.0, 9.0])
    rk, rd, rv = adaptation_rates(eps, e, edot, g, *q)
    np.testing.assert_allclose(rk[0], 3000 * 0.4 * 0.1 * g)  # 120 * g: stiffness grows
    np.testing.assert_allclose(rk[1], 3000 * -0.1 * -0.05 * g)  # eps e > 0 again: grows
    np.testing.assert_allclose(rd[0], 90 * 0.4 * 0.2 * g)
    np.testing.assert_allclose(rd[1], 0.0)
    np.testing.assert_allclose(rv[0], 9 * 0.4 * g)
    np.testing.assert_allclose(rv[1], 9 * -0.1 * g)  # feed-forward falls


def test_theta_constant_when_errors_vanish():
    g = np.array([0.2, 0.3, 0.5])
    zero = np.zeros(3)
    e, edot = tracking_errors(np.ones(3), np.ones(3), np.ones(3), np.ones(3))
    rates = adaptation_rates(
        sliding_error(e, edot, 5.0),
        e,
        edot,
        g,
        np.full(3, 3000.0),
        np.full(3, 90.0),
        np.full(3, 9.0),
    )
    for rate in rates:
        np.testing.assert_array_equal(rate, np.zeros((3, 3)))
    assert zero.shape == (3,)


def test_zero_learning_rate_keeps_feedforward():
    _, _, rv = adaptation_rates(
        np.array([1.0]),
        np.array([1.0]),
        np.array([1.0]),
        np.ones(2),
        np.array([1.0]),
        np.array([1.0]),
        np.array([0.0]),
    )
    np.testing.assert_array_equal(rv, 0.0)


def test_profiles_are_weighted_sums():
    theta = np.array([[100.0, 300.0]]), np.array([[10.0, 30.0]]), np.array([[1.0, -1.0]])
    k, d, v = compliant_profiles(*theta, np.array([0.5, 0.5]))
    np.testing.assert_allclose([k[0], d[0], v[0]], [200.0, 20.0, 0.0])


def test_commanded_force_hand_computed():
    # 1 axis, M = 5, C = 0.5, G = 2, x_d' = 0.1, x_d'' = 0, e = 0.05, e' = -0.02, pi = 4, L = 3
    e, edot = tracking_errors(np.array([0.15]), np.array([0.08]), np.array([0.1]), np.array([0.1]))
    np.testing.assert_allclose([e[0], edot[0]], [0.05, -0.02])
    eps = sliding_error(e, edot, 4.0)  # 0.18
    xe_dot, xe_ddot = reference_motion(np.array([0.1]), np.array([0.0]), e, edot, 4.0)
    np.testing.assert_allclose([xe_dot[0], xe_ddot[0]], [0.1 - 0.2, 0.08])
    f0 = nominal_force(
        np.array([[5.0]]), np.array([[0.5]]), np.array([2.0]), xe_dot, xe_ddot, np.array([3.0]), eps
    )
    np.testing.assert_allclose(f0, [5 * 0.08 + 0.5 * -0.1 + 2.0 - 3 * 0.18])
    u = impedance_force(np.array([100.0]), np.array([10.0]), e, edot)
    np.testing.assert_allclose(u, [100 * 0.05 + 10 * -0.02])
    np.testing.assert_allclose(commanded_force(f0, u, np.array([1.0])), f0 - u - 1.0)


def test_duan_law_presses_harder_when_force_is_too_low():
    # Reaction below the desired force: Phi grows, and the admittance accelerates the
    # commanded position against the reaction (negative along the axis).
    phi = duan_adaptation_step(np.array([0.0]), np.array([1.0]), sigma=0.01, b=10.0)
    np.testing.assert_allclose(phi, [0.001])
    acc = duan_admittance_acceleration(
        np.zeros(1), np.zeros(1), phi, np.array([1.0]), np.ones(1), np.array([10.0]), np.zeros(1)
    )
    assert acc[0] < 0


def test_forgetting_rates_subtract_gamma_theta():
    from hlcmp_drake.core.adaptation import forgetting_rates

    rates, theta = np.array([1.0, -2.0, 0.5]), np.array([10.0, 4.0, -6.0])
    np.testing.assert_array_equal(forgetting_rates(rates, theta, 0.0), rates)
    np.testing.assert_allclose(forgetting_rates(rates, theta, 0.1), [0.0, -2.4, 1.1])
