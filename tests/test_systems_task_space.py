"""hlcmp_drake.systems.task_space: the task-space terms against Drake and finite differences,
J^T f_c and the null space on the iiwa at a static pose, and the saturating force-to-torque
map."""

import numpy as np
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable

from hlcmp_drake.systems.task_space import TaskForceToJointTorque, TaskSpaceDynamics


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
