"""hlcmp_drake.systems.task_space: the task-space terms against Drake and finite differences,
J^T f_c and the null space on the iiwa at a static pose, the saturating force-to-torque map,
and the terms read once per state against Drake's separate queries."""

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable

from hlcmp_drake.systems.task_space import (
    TaskForceToJointTorque,
    TaskSpaceDynamics,
    TaskSpaceModel,
    axis_rows,
)


def test_force_to_torque_saturates():
    torque_map = TaskForceToJointTorque(2, [10.0, 10.0, 1.0])
    context = torque_map.CreateDefaultContext()
    torque_map.force.FixValue(context, [2.0, 3.0])
    torque_map.jacobian.FixValue(context, [1, 0, 1, 0, 1, 1])
    np.testing.assert_allclose(
        torque_map.GetOutputPort("joint_torque").Eval(context), [2.0, 3.0, 1.0]
    )
    np.testing.assert_allclose(torque_map.GetOutputPort("saturated").Eval(context), [1])


DOUBLE_PENDULUM = """<?xml version="1.0"?>
<sdf version="1.9"><model name="pendulum">
  <link name="l1"><pose>0 0 0 0 0 0</pose><inertial><pose>0 0 -0.3 0 0 0</pose><mass>2</mass>
    <inertia><ixx>0.05</ixx><iyy>0.06</iyy><izz>0.01</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia></inertial></link>
  <link name="l2"><pose>0 0 -0.6 0 0 0</pose><inertial><pose>0 0 -0.25 0 0 0</pose><mass>1</mass>
    <inertia><ixx>0.02</ixx><iyy>0.03</iyy><izz>0.01</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia></inertial></link>
  <link name="l3"><pose>0 0 -1.1 0 0 0</pose><inertial><mass>0.5</mass>
    <inertia><ixx>0.01</ixx><iyy>0.01</iyy><izz>0.01</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia></inertial></link>
  <joint name="j1" type="revolute"><parent>world</parent><child>l1</child>
    <axis><xyz>0 1 0</xyz></axis></joint>
  <joint name="j2" type="revolute"><parent>l1</parent><child>l2</child>
    <axis><xyz>1 0 0</xyz></axis></joint>
  <joint name="j3" type="revolute"><parent>l2</parent><child>l3</child>
    <axis><xyz>0 1 0</xyz></axis></joint>
</model></sdf>"""


def test_task_space_dynamics_against_drake_and_finite_differences():
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(DOUBLE_PENDULUM, "sdf")
    plant.Finalize()
    frame, point = plant.GetBodyByName("l3").body_frame(), np.array([0.0, 0.0, -0.1])
    system = TaskSpaceDynamics(plant, frame, point, axes=[0, 2])
    context = system.CreateDefaultContext()
    q, v = np.array([0.4, -0.3, 0.7]), np.array([0.5, -1.2, 0.8])
    system.plant_state.FixValue(context, np.concatenate([q, v]))
    terms = system.terms(context)
    plant_context = plant.CreateDefaultContext()
    plant.SetPositions(plant_context, q)
    plant.SetVelocities(plant_context, v)
    world = plant.world_frame()

    def jacobian_at(qq):
        plant.SetPositions(plant_context, qq)
        return plant.CalcJacobianTranslationalVelocity(
            plant_context, JacobianWrtVariable.kV, frame, point.reshape(3, 1), world, world
        )[[0, 2]]

    jac = jacobian_at(q)
    np.testing.assert_allclose(terms.jacobian, jac)
    np.testing.assert_allclose(terms.velocity, jac @ v)
    mass = plant.CalcMassMatrix(plant_context)
    np.testing.assert_allclose(terms.inertia, np.linalg.inv(jac @ np.linalg.solve(mass, jac.T)))
    # Jdot by central differences along v; C(q, v) from Christoffel symbols by finite
    # differences of M(q): both must agree with the polarization inside the system.
    h = 1e-6
    jdot = (jacobian_at(q + h * v) - jacobian_at(q - h * v)) / (2 * h)

    def mass_at(qq):
        plant.SetPositions(plant_context, qq)
        return plant.CalcMassMatrix(plant_context)

    dm = [
        (mass_at(q + h * np.eye(3)[k]) - mass_at(q - h * np.eye(3)[k])) / (2 * h) for k in range(3)
    ]
    coriolis_q = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            coriolis_q[i, j] = sum(
                0.5 * (dm[k][i, j] + dm[j][i, k] - dm[i][j, k]) * v[k] for k in range(3)
            )
    plant.SetPositions(plant_context, q)
    jbar = np.linalg.solve(mass, jac.T) @ terms.inertia
    expected = jbar.T @ coriolis_q @ jbar - terms.inertia @ jdot @ jbar
    np.testing.assert_allclose(terms.coriolis, expected, atol=1e-6)
    gravity = -plant.CalcGravityGeneralizedForces(plant_context)
    np.testing.assert_allclose(terms.gravity, jbar.T @ gravity)


def _acceleration(arm, tau):
    context = arm.plant.CreateDefaultContext()
    arm.plant.SetPositionsAndVelocities(context, arm.state)
    mass = arm.plant.CalcMassMatrix(context)
    bias = arm.plant.CalcBiasTerm(context) - arm.plant.CalcGravityGeneralizedForces(context)
    return np.linalg.solve(mass, tau - bias)


def test_task_force_produces_the_endpoint_acceleration_it_should_against_gravity(arm):
    """tau = J^T (f + G_x) + N^T G: gravity is cancelled exactly and the tip accelerates
    by Lambda^-1 f, as the task-space model M x'' + C x' + G = f_c (Eq. 2) says."""
    t = arm.terms
    for force in (np.zeros(3), np.array([5.0, -3.0, 10.0])):
        tau = t.jacobian.T @ (force + t.gravity) + t.null_space @ t.joint_gravity
        tip_acceleration = t.jacobian @ _acceleration(arm, tau)  # J' v = 0 at rest
        np.testing.assert_allclose(tip_acceleration, np.linalg.solve(t.inertia, force), atol=1e-9)


def test_null_space_torques_do_not_move_the_tool_point(arm):
    t = arm.terms
    rng = np.random.default_rng(1)
    for _ in range(3):
        tau = t.null_space @ rng.normal(0, 10, 7) + t.joint_gravity  # gravity held
        np.testing.assert_allclose(t.jacobian @ _acceleration(arm, tau), 0.0, atol=1e-9)


def test_axis_rows_pick_the_axes():
    rows = np.arange(6.0)
    for axes in ([0, 1, 2], [1, 2], [2], [0, 2], [2, 0], [1, 0]):
        for offset in (0, 3):
            np.testing.assert_array_equal(rows[axis_rows(axes, offset)], np.add(axes, offset))
    assert axis_rows([0, 1, 2]) == slice(0, 3) and axis_rows([1, 2], 3) == slice(4, 6)


def _drake_terms(plant, frame, point, axes, state):
    """The position-dependent terms as separate Drake queries on a fresh context."""
    context = plant.CreateDefaultContext()
    plant.SetPositionsAndVelocities(context, state)
    world = plant.world_frame()
    return dict(
        position=plant.CalcPointsPositions(context, frame, point.reshape(3, 1), world)[axes, 0],
        jacobian=plant.CalcJacobianTranslationalVelocity(
            context, JacobianWrtVariable.kV, frame, point.reshape(3, 1), world, world
        )[axes],
        angular_jacobian=plant.CalcJacobianAngularVelocity(
            context, JacobianWrtVariable.kV, frame, world, world
        ),
        rotation=frame.CalcRotationMatrixInWorld(context).matrix(),
        joint_gravity=-plant.CalcGravityGeneralizedForces(context),
    )


@pytest.mark.parametrize("axes", [[0, 1, 2], [0, 2], [1, 2]])
def test_terms_read_once_equal_drakes_separate_queries(axes):
    """`terms` sets only the positions and reads J and J_w from one spatial Jacobian: at a
    second state, after a Coriolis product left other velocities in the context, every term
    equals Drake's own query on a fresh context, and C_x w equals a fresh model's, exactly
    up to the last bits (1e-14 of each term's scale)."""
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(DOUBLE_PENDULUM, "sdf")
    plant.Finalize()
    frame, point = plant.GetBodyByName("l3").body_frame(), np.array([0.05, -0.02, -0.1])
    model = TaskSpaceModel(plant, frame, point, axes)
    rng = np.random.default_rng(7)
    first, second = (np.concatenate([rng.normal(0, 0.6, 3), rng.normal(0, 1.0, 3)]) for _ in "ab")
    w = rng.normal(0, 0.5, len(axes))
    model.terms(first, coriolis_matrix=False).coriolis @ w  # leaves v - Jbar w in the context
    terms = model.terms(second, coriolis_matrix=False)
    fresh = TaskSpaceModel(plant, frame, point, axes).terms(second, coriolis_matrix=False)
    expected = _drake_terms(plant, frame, point, axes, second)
    expected["velocity"] = expected["jacobian"] @ second[3:]
    got = {name: getattr(terms, name) for name in expected}
    got["coriolis product"] = terms.coriolis @ w
    expected["coriolis product"] = fresh.coriolis @ w
    assert np.abs(expected["coriolis product"]).max() > 1e-2  # a product that tells
    for name, value in expected.items():
        scale = max(1.0, float(np.abs(value).max()))
        np.testing.assert_allclose(got[name], value, rtol=0, atol=1e-14 * scale, err_msg=name)
