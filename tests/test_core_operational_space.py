"""hlcmp_drake.core.operational_space.rotation_vector: the principal rotation vector of a
rotation matrix against Drake's angle-axis at every angle and through each of its four
branches, on both kernel paths."""

import numpy as np
import pytest
from pydrake.common.eigen_geometry import AngleAxis
from pydrake.math import RotationMatrix

from hlcmp_drake.core.kernels import implementation, numba_available
from hlcmp_drake.core.operational_space import rotation_vector


def _random_axes(rng, count):
    axes = rng.normal(size=(count, 3))
    return axes / np.linalg.norm(axes, axis=1, keepdims=True)


def _rotations(rng):
    """(axis, angle) pairs: random, small, near pi, and near pi about each world axis (the
    quaternion's largest component is then x, y or z: each branch)."""
    angles = np.concatenate(
        [
            rng.uniform(0.0, np.pi, 200),
            10.0 ** rng.uniform(-12, -2, 50),
            np.pi - 10.0 ** rng.uniform(-8, -2, 50),
        ]
    )
    pairs = list(zip(_random_axes(rng, len(angles)), angles))
    for k in range(3):
        axis = np.eye(3)[k] + rng.normal(0, 0.05, 3)
        pairs += [(axis / np.linalg.norm(axis), np.pi - d) for d in (1e-6, 0.1, 0.5)]
    return pairs


def test_the_rotation_vector_is_drakes_angle_axis():
    rng = np.random.default_rng(11)
    for axis, angle in _rotations(rng):
        rotation = RotationMatrix(AngleAxis(angle, axis)).matrix()
        drake = RotationMatrix(rotation).ToAngleAxis()
        expected = drake.axis() * drake.angle()
        np.testing.assert_allclose(rotation_vector(rotation), expected, rtol=0, atol=2e-15)
        # and it is the rotation's own vector (up to the conditioning of the axis near pi)
        np.testing.assert_allclose(
            rotation_vector(rotation), axis * angle, rtol=0, atol=1e-15 + 1e-9 * (angle > 3)
        )
    np.testing.assert_array_equal(rotation_vector(np.eye(3)), np.zeros(3))


def test_at_pi_either_opposite_vector():
    for axis in (*np.eye(3), np.array([1.0, 2.0, -2.0]) / 3.0):
        got = rotation_vector(RotationMatrix(AngleAxis(np.pi, axis)).matrix())
        assert min(np.abs(got - np.pi * axis).max(), np.abs(got + np.pi * axis).max()) < 1e-7


@pytest.mark.skipif(not numba_available(), reason="numba is not installed")
def test_the_compiled_rotation_vector_agrees_with_numpy():
    compiled = implementation(rotation_vector, "compiled")
    rng = np.random.default_rng(12)
    for axis, angle in _rotations(rng):
        rotation = RotationMatrix(AngleAxis(angle, axis)).matrix()
        np.testing.assert_allclose(
            compiled(rotation), rotation_vector(rotation), rtol=0, atol=1e-15
        )
