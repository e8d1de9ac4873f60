"""hlcmp_drake.core.task_inertia: the exact inverse away from singularities, the floor on
the lost direction near one, and a floor that does not depend on units or on the frame."""

import numpy as np
import pytest

from hlcmp_drake.core.task_inertia import EIGENVALUE_FLOOR, conditioned_task_inertia


def _inverse_inertia(rng, smallest):
    """A 6 x 6 J M^-1 J^T with rotational entries ~100 (1/(kg m^2)), translational ~0.5
    (1/kg), and one direction whose block-scaled eigenvalue is about `smallest`."""
    jac = rng.normal(size=(6, 7))
    jac[5] = jac[4] + smallest * rng.normal(size=7)  # two task rows nearly dependent
    jac[:3] *= 10.0
    a = rng.normal(size=(7, 7))
    return jac @ np.linalg.inv(a @ a.T + 7 * np.eye(7)) @ jac.T


def test_the_exact_inverse_where_nothing_is_floored():
    phi = _inverse_inertia(np.random.default_rng(0), 1.0)
    inertia, floored = conditioned_task_inertia(phi)
    assert floored == 0
    np.testing.assert_array_equal(inertia, np.linalg.inv(phi))


def test_a_near_singular_direction_is_floored_and_bounded():
    phi = _inverse_inertia(np.random.default_rng(1), 1e-5)
    inertia, floored = conditioned_task_inertia(phi)
    assert floored == 1
    assert np.linalg.norm(np.linalg.inv(phi), 2) > 1e4 * np.linalg.norm(inertia, 2)
    scale = np.repeat(1 / np.sqrt([np.trace(phi[:3, :3]) / 3, np.trace(phi[3:, 3:]) / 3]), 3)
    assert np.linalg.norm(inertia, 2) <= scale.max() ** 2 / EIGENVALUE_FLOOR


def test_the_floor_does_not_depend_on_units_or_on_the_frame():
    """Metres to millimetres scales the translational rows and columns; a rotation of the
    world turns both blocks: the same directions are floored, and Lambda transforms as an
    inertia does."""
    phi = _inverse_inertia(np.random.default_rng(2), 3e-4)
    inertia, floored = conditioned_task_inertia(phi)
    assert floored == 1
    to_mm = np.diag([1.0, 1, 1, 1e3, 1e3, 1e3])
    inertia_mm, floored_mm = conditioned_task_inertia(to_mm @ phi @ to_mm)
    assert floored_mm == floored
    np.testing.assert_allclose(to_mm @ inertia_mm @ to_mm, inertia, rtol=1e-9)
    angle = 0.7
    c, s = np.cos(angle), np.sin(angle)
    turn = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    rotation = np.kron(np.eye(2), turn)
    inertia_turned, floored_turned = conditioned_task_inertia(rotation @ phi @ rotation.T)
    assert floored_turned == floored
    np.testing.assert_allclose(
        rotation.T @ inertia_turned @ rotation, inertia, rtol=1e-9, atol=1e-12
    )


def test_a_zero_block_is_refused():
    with pytest.raises(ValueError, match="zero block"):
        conditioned_task_inertia(np.diag([1.0, 2.0, 3.0, 0.0, 0.0, 0.0]))
