"""hlcmp_drake.systems.spatial_task_space on the insertion's iiwa: the spatial Jacobian
against finite differences of the tool pose, Lambda's definition and its floor near the
stretched arm, C_x against Christoffel symbols, the translational rows against the 3-D
model, the dynamically consistent null space, and the saturating wrench-to-torque map."""

import numpy as np
import pytest

from hlcmp_drake.core import quaternion as quat
from hlcmp_drake.core.task_inertia import EIGENVALUE_FLOOR, conditioned_task_inertia
from hlcmp_drake.systems.spatial_task_space import SpatialTaskSpaceModel, wrench_to_joint_torque

MOVING = np.array([0.4, -0.7, 0.5, 0.3, -0.2, 0.6, -0.9])  # a joint velocity [rad/s]


@pytest.fixture
def model(arm):
    return SpatialTaskSpaceModel(arm.plant, arm.tip)


def _at_rest(arm, model, q=None):
    q = arm.setup.q0 if q is None else q
    return model.terms(np.concatenate([q, np.zeros(7)]))


def _mass(arm, model):
    return arm.plant.CalcMassMatrix(model.context)


def _acceleration(arm, q, tau):
    context = arm.plant.CreateDefaultContext()
    arm.plant.SetPositions(context, q)
    mass = arm.plant.CalcMassMatrix(context)
    return np.linalg.solve(mass, tau + arm.plant.CalcGravityGeneralizedForces(context))


def test_the_jacobian_is_the_derivative_of_the_tool_pose(arm, model):
    """Rows 0-2: the world angular velocity, from R(q + h e_k) R(q - h e_k)^T; rows 3-5:
    the tool point's velocity, from its positions; angular first, as Drake orders them."""
    q0, h = arm.setup.q0 + 0.1, 1e-6
    jac = model.terms(np.concatenate([q0, MOVING])).jacobian
    for k in range(7):
        step = h * np.eye(7)[k]
        plus, minus = _at_rest(arm, model, q0 + step), _at_rest(arm, model, q0 - step)
        turn = quat.to_rotation_vector(
            quat.multiply(plus.orientation, quat.conjugate(minus.orientation))
        )
        np.testing.assert_allclose(turn / (2 * h), jac[:3, k], atol=1e-8)
        np.testing.assert_allclose(
            (plus.position - minus.position) / (2 * h), jac[3:, k], atol=1e-8
        )
    terms = model.terms(np.concatenate([q0, MOVING]))
    np.testing.assert_allclose(terms.spatial_velocity, jac @ MOVING)


def test_lambda_is_the_inverse_of_the_inverse_task_inertia_at_a_working_pose(arm, model):
    terms = _at_rest(arm, model)
    jac, mass = terms.jacobian, _mass(arm, model)
    phi = jac @ np.linalg.solve(mass, jac.T)
    assert terms.floored == 0
    np.testing.assert_array_equal(terms.inertia, np.linalg.inv(phi))
    # the margin the docstring of conditioned_task_inertia states: the smallest block-scaled
    # eigenvalue at the insertion's start posture
    scale = np.repeat(1 / np.sqrt([np.trace(phi[:3, :3]) / 3, np.trace(phi[3:, 3:]) / 3]), 3)
    smallest = np.linalg.eigvalsh(scale[:, None] * phi * scale[None, :])[0]
    assert 0.02 < smallest < 0.05 and smallest > 10 * EIGENVALUE_FLOOR


def _near_stretched(angle):
    """The arm bent by `angle` [rad] at joints 2, 4, 6 (all zero is the arm stretched
    upright, singular: no joint moves the tool along the arm)."""
    q = np.zeros(7)
    q[1], q[3], q[5] = angle, -2 * angle, angle
    return q


def test_near_the_stretched_arm_lambda_stays_bounded_and_exact_off_the_singular_directions(
    arm, model
):
    bounds = []
    for angle in (0.03, 0.01, 1e-4, 0.0):
        terms = _at_rest(arm, model, _near_stretched(angle))
        jac, mass = terms.jacobian, _mass(arm, model)
        phi = jac @ np.linalg.solve(mass, jac.T)
        assert np.linalg.cond(phi) > 1e4 and terms.floored >= 1
        inertia, floored = conditioned_task_inertia(phi)
        np.testing.assert_array_equal(inertia, terms.inertia)
        # Lambda Phi is the identity on the directions kept and shrinks the floored ones
        gains = np.sort(np.linalg.eigvals(inertia @ phi).real)
        np.testing.assert_allclose(gains[floored:], 1.0, atol=1e-6)
        assert np.all(gains[:floored] < 1.0)
        bounds.append(np.linalg.norm(terms.inertia, 2))
    scale_bound = 1 / EIGENVALUE_FLOOR * np.max(1 / np.diag(phi)) * 6
    assert max(bounds) < scale_bound
    # the exact inverse at the stretched arm is not even finite in a meaningful sense
    assert np.linalg.cond(phi) > 1e15


def test_the_floor_refuses_a_task_no_joint_moves():
    with pytest.raises(ValueError, match="zero block"):
        conditioned_task_inertia(np.diag([1.0, 1.0, 1.0, 0.0, 0.0, 0.0]))


def test_the_coriolis_term_against_christoffel_symbols_and_jdot(arm, model):
    q, v, h = arm.setup.q0 + 0.1, MOVING, 1e-6
    terms = model.terms(np.concatenate([q, v]))
    mass, inertia = _mass(arm, model), terms.inertia
    jbar = np.linalg.solve(mass, terms.jacobian.T) @ inertia

    def at(qq):
        t = _at_rest(arm, model, qq)
        return t.jacobian, _mass(arm, model)

    jdot = (at(q + h * v)[0] - at(q - h * v)[0]) / (2 * h)
    dm = [(at(q + h * np.eye(7)[k])[1] - at(q - h * np.eye(7)[k])[1]) / (2 * h) for k in range(7)]
    coriolis_q = np.array(
        [
            [sum(0.5 * (dm[k][i, j] + dm[j][i, k] - dm[i][j, k]) * v[k] for k in range(7))
             for j in range(7)]
            for i in range(7)
        ]
    )  # fmt: skip
    expected = jbar.T @ coriolis_q @ jbar - inertia @ jdot @ jbar
    np.testing.assert_allclose(terms.coriolis, expected, atol=1e-5 * np.abs(expected).max())
    operator = model.terms(np.concatenate([q, v]), coriolis_matrix=False).coriolis
    w = np.array([0.2, -0.1, 0.3, 0.05, -0.02, 0.04])
    np.testing.assert_allclose(operator @ w, terms.coriolis @ w, rtol=1e-9, atol=1e-12)


def test_the_translational_rows_reduce_to_the_3d_task_space_model(arm, model):
    terms, three = _at_rest(arm, model), arm.terms
    np.testing.assert_allclose(terms.position, three.position, atol=1e-15)
    np.testing.assert_allclose(terms.jacobian[3:], three.jacobian, atol=1e-14)
    inverse = np.linalg.inv(terms.inertia)
    np.testing.assert_allclose(inverse[3:, 3:], np.linalg.inv(three.inertia), rtol=1e-10)
    np.testing.assert_allclose(
        (inverse @ terms.gravity)[3:], np.linalg.solve(three.inertia, three.gravity), rtol=1e-9
    )
    # ... but the 6-D Lambda's translational block is not the 3-D Lambda: rotation couples
    assert np.abs(terms.inertia[3:, 3:] - three.inertia).max() > 0.1 * np.abs(three.inertia).max()


def test_a_wrench_gives_the_spatial_acceleration_it_should_against_gravity(arm, model):
    """tau = J^T (F + p) + N^T G at rest: V' = Lambda^-1 F (Eq. 2 in 6-D)."""
    terms = _at_rest(arm, model)
    for wrench in (np.zeros(6), np.array([0.5, -1.0, 2.0, 5.0, -3.0, 10.0])):
        tau = terms.jacobian.T @ (wrench + terms.gravity) + terms.null_space @ terms.joint_gravity
        np.testing.assert_allclose(
            terms.jacobian @ _acceleration(arm, arm.setup.q0, tau),
            np.linalg.solve(terms.inertia, wrench),
            atol=1e-9,
        )


def test_the_null_space_is_the_seventh_joints_and_moves_no_part_of_the_pose(arm, model):
    terms = _at_rest(arm, model)
    projector, mass = terms.null_space, _mass(arm, model)
    np.testing.assert_allclose(projector @ projector, projector, atol=1e-10)
    np.testing.assert_allclose(
        terms.jacobian @ np.linalg.solve(mass, projector), 0.0, atol=1e-10
    )  # J M^-1 N^T = 0: dynamically consistent
    assert np.linalg.matrix_rank(projector, tol=1e-8) == 1
    rng = np.random.default_rng(1)
    for _ in range(3):
        tau = projector @ rng.normal(0, 10, 7) + terms.joint_gravity
        np.testing.assert_allclose(
            terms.jacobian @ _acceleration(arm, arm.setup.q0, tau), 0.0, atol=1e-9
        )


def test_the_wrench_map_adds_gravity_and_posture_in_the_null_space_and_saturates(arm, model):
    terms = _at_rest(arm, model)
    limits = np.array([320.0, 320, 176, 176, 110, 40, 40])
    posture = np.array([0.0, 0, 0, 0, 0, 0, 3.0])
    torque, saturated = wrench_to_joint_torque(terms, np.zeros(6), posture, limits)
    np.testing.assert_allclose(
        torque, terms.jacobian.T @ np.zeros(6) + terms.null_space @ (terms.joint_gravity + posture)
    )
    assert saturated == 0
    torque, saturated = wrench_to_joint_torque(terms, np.full(6, 1e4), posture, limits)
    assert saturated > 0 and np.all(np.abs(torque) <= limits)
