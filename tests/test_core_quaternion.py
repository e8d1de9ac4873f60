"""hlcmp_drake.core.quaternion: product, Exp/Log, rotation, the left Jacobian, the
hemisphere fix and the representative of a rotation beyond pi."""

import numpy as np
import pytest

from hlcmp_drake.core import quaternion as quat


def _random_rotation_vectors(rng, count, largest=np.pi):
    axes = rng.normal(size=(count, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    return axes * rng.uniform(0.0, largest, (count, 1))


def test_a_quarter_turn_about_z_takes_x_to_y():
    q = quat.from_rotation_vector([0.0, 0.0, np.pi / 2])
    np.testing.assert_allclose(q, [np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)])
    np.testing.assert_allclose(quat.rotate(q, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-15)


def test_the_product_composes_rotations_and_the_conjugate_inverts():
    rng = np.random.default_rng(0)
    a, b = (quat.from_rotation_vector(_random_rotation_vectors(rng, 50)) for _ in range(2))
    v = rng.normal(size=(50, 3))
    np.testing.assert_allclose(
        quat.rotate(quat.multiply(a, b), v), quat.rotate(a, quat.rotate(b, v)), atol=1e-12
    )
    np.testing.assert_allclose(
        quat.multiply(a, quat.conjugate(a)), np.tile([1, 0, 0, 0], (50, 1)), atol=1e-15
    )


def test_log_inverts_exp_and_ignores_the_sign():
    rng = np.random.default_rng(1)
    v = _random_rotation_vectors(rng, 200, largest=np.pi - 1e-6)
    q = quat.from_rotation_vector(v)
    np.testing.assert_allclose(quat.to_rotation_vector(q), v, atol=1e-12)
    np.testing.assert_allclose(quat.to_rotation_vector(-q), v, atol=1e-12)
    tiny = np.array([1e-12, -2e-12, 3e-13])
    np.testing.assert_allclose(quat.to_rotation_vector(quat.from_rotation_vector(tiny)), tiny)
    assert np.linalg.norm(quat.from_rotation_vector(v), axis=1) == pytest.approx(1.0)


def test_beyond_pi_exp_gives_the_other_hemisphere_of_the_principal_rotation():
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    q = quat.from_rotation_vector(np.radians(270.0) * axis)
    assert q[0] < 0
    np.testing.assert_allclose(quat.to_rotation_vector(q), np.radians(-90.0) * axis, atol=1e-12)


def test_the_left_jacobian_maps_the_rotation_vector_rate_to_the_world_angular_velocity():
    rng = np.random.default_rng(2)
    h = 1e-6
    for v, vdot in zip(_random_rotation_vectors(rng, 20, largest=5.5), rng.normal(size=(20, 3))):
        # world frame: q(t + h) = Exp(omega h / 2) q(t)
        ahead = quat.from_rotation_vector(v + h * vdot)
        behind = quat.from_rotation_vector(v - h * vdot)
        omega = quat.to_rotation_vector(quat.multiply(ahead, quat.conjugate(behind))) / (2 * h)
        np.testing.assert_allclose(quat.left_jacobian(v) @ vdot, omega, atol=1e-7)
    np.testing.assert_allclose(quat.left_jacobian(np.zeros(3)), np.eye(3))


def test_hemisphere_continuous_undoes_random_sign_flips():
    rng = np.random.default_rng(3)
    steps = np.cumsum(0.02 * rng.normal(size=(300, 3)), axis=0)
    smooth = quat.from_rotation_vector(steps)
    flipped = smooth * rng.choice([-1.0, 1.0], 300)[:, None]
    fixed = quat.hemisphere_continuous(flipped)
    np.testing.assert_allclose(fixed, smooth * np.sign(flipped[0, 0] / smooth[0, 0]))
    assert np.all(np.sum(fixed[1:] * fixed[:-1], axis=1) > 0)


def test_the_nearest_representative_keeps_a_turn_beyond_pi_in_its_direction():
    axis = np.array([0.0, 0.6, 0.8])
    principal = quat.to_rotation_vector(quat.from_rotation_vector(np.radians(270.0) * axis))
    np.testing.assert_allclose(principal, np.radians(-90.0) * axis, atol=1e-12)
    kept = quat.nearest_rotation_vector(principal, np.radians(260.0) * axis)
    np.testing.assert_allclose(kept, np.radians(270.0) * axis, atol=1e-12)
    # More than a whole turn, and a reference at zero (the principal value).
    np.testing.assert_allclose(
        quat.nearest_rotation_vector(principal, np.radians(600.0) * axis),
        np.radians(630.0) * axis,
        atol=1e-12,
    )
    np.testing.assert_allclose(quat.nearest_rotation_vector(principal, np.zeros(3)), principal)


def test_unwrapping_a_turn_of_400_degrees_is_continuous():
    axis = np.array([1.0, -1.0, 1.0]) / np.sqrt(3.0)
    angles = np.radians(np.linspace(0.0, 400.0, 401))
    principal = quat.to_rotation_vector(quat.from_rotation_vector(angles[:, None] * axis))
    assert np.abs(np.diff(principal, axis=0)).max() > 1.0  # it jumps where it passes pi
    unwrapped = quat.unwrap_rotation_vectors(principal, np.zeros(3))
    np.testing.assert_allclose(unwrapped, angles[:, None] * axis, atol=1e-9)


def test_the_geodesic_angle():
    a = quat.from_rotation_vector([0.3, 0.0, 0.0])
    b = quat.from_rotation_vector([0.0, 0.4, 0.0])
    expected = np.linalg.norm(quat.to_rotation_vector(quat.multiply(a, quat.conjugate(b))))
    assert quat.geodesic_angle(a, -b) == pytest.approx(expected)
    assert quat.geodesic_angle(a, a) == pytest.approx(0.0, abs=1e-12)


def test_the_left_jacobian_rate_is_its_derivative_along_the_motion():
    rng = np.random.default_rng(4)
    h = 1e-5
    # Both sides of the Taylor switch at 0.05 rad, and beyond pi.
    for angle in (1e-6, 0.02, 0.0499, 0.0501, 0.3, 1.0, 3.0, 4.7, 6.0):
        axis = rng.normal(size=3)
        v, vdot = angle * axis / np.linalg.norm(axis), rng.normal(size=3)
        ahead, behind = quat.left_jacobian(v + h * vdot), quat.left_jacobian(v - h * vdot)
        np.testing.assert_allclose(
            quat.left_jacobian_rate(v, vdot), (ahead - behind) @ vdot / (2 * h), atol=1e-9
        )


def test_the_matrix_rotates_as_the_quaternion_does():
    rng = np.random.default_rng(9)
    q = quat.from_rotation_vector(_random_rotation_vectors(rng, 20, largest=2 * np.pi))
    v = rng.normal(size=(20, 3))
    matrices = quat.to_matrix(q)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", matrices, v), quat.rotate(q, v), atol=1e-14)
    np.testing.assert_allclose(quat.to_matrix(-q[0]), matrices[0], atol=1e-15)
    np.testing.assert_allclose(matrices[3] @ matrices[3].T, np.eye(3), atol=1e-14)


def test_cross_is_numpys_cross_to_the_bit():
    from hlcmp_drake.core.quaternion import cross

    rng = np.random.default_rng(7)
    a, b = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    np.testing.assert_array_equal(cross(a, b), np.cross(a, b))
    np.testing.assert_array_equal(cross(a[0], b), np.cross(a[0], b))  # broadcast
    np.testing.assert_array_equal(cross(a[1], b[2]), np.cross(a[1], b[2]))
    assert cross(a[1], b[2]).shape == (3,)
