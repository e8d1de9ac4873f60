"""hlcmp_drake.core.adaptation: the adaptation law (Eq. 31) and the compliant profiles (Eq.
14), by hand."""

import numpy as np

from hlcmp_drake.core.adaptation import adaptation_rates, compliant_profiles
from hlcmp_drake.core.control_law import (
    sliding_error,
    tracking_errors,
)


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


def test_forgetting_rates_subtract_gamma_theta():
    from hlcmp_drake.core.adaptation import forgetting_rates

    rates, theta = np.array([1.0, -2.0, 0.5]), np.array([10.0, 4.0, -6.0])
    np.testing.assert_array_equal(forgetting_rates(rates, theta, 0.0), rates)
    np.testing.assert_allclose(forgetting_rates(rates, theta, 0.1), [0.0, -2.4, 1.1])
