"""Task-space control on the iiwa: J^T f_c and the null-space terms at a static pose."""

import dataclasses as dc

import numpy as np
import pytest
from pydrake.multibody.parsing import ModelDirectives, Parser, ProcessModelDirectives
from pydrake.multibody.plant import MultibodyPlant

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.io.paths import register_package
from hlcmp_drake.systems.arm import NullSpaceImpedance
from hlcmp_drake.systems.task_space import TaskSpaceDynamics
from hlcmp_drake.worlds.arm import prepare as prepare_arm
from hlcmp_drake.worlds.models import scoped_frame


@pytest.fixture(scope="module")
def arm():
    scenario, _ = load_scenario("insertion")
    setup = prepare_arm(scenario)
    plant = MultibodyPlant(0.0)
    parser = Parser(plant)
    register_package(parser.package_map())
    ProcessModelDirectives(ModelDirectives(directives=scenario.directives), plant, parser)
    plant.Finalize()
    tip = scoped_frame(plant, scenario.task.tool_frame)
    task_space = TaskSpaceDynamics(plant, tip)
    context = task_space.CreateDefaultContext()
    state = np.concatenate([setup.q0, np.zeros(7)])
    task_space.plant_state.FixValue(context, state)
    return dc.make_dataclass("Arm", ["scenario", "setup", "plant", "tip", "terms", "state"])(
        scenario, setup, plant, tip, task_space.terms(context), state
    )


def _acceleration(arm, tau):
    context = arm.plant.CreateDefaultContext()
    arm.plant.SetPositionsAndVelocities(context, arm.state)
    mass = arm.plant.CalcMassMatrix(context)
    bias = arm.plant.CalcBiasTerm(context) - arm.plant.CalcGravityGeneralizedForces(context)
    return np.linalg.solve(mass, tau - bias)


def test_start_posture_puts_the_tool_at_the_demonstration_start_pointing_down(arm):
    np.testing.assert_allclose(arm.terms.position, arm.setup.dmp.start, atol=2e-4)
    np.testing.assert_allclose(arm.setup.tool_orientation.col(2), [0, 0, -1], atol=2e-3)


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


def test_null_space_impedance_holds_orientation_and_gravity(arm):
    system = NullSpaceImpedance(
        arm.plant, arm.tip, arm.setup.tool_orientation, arm.setup.q0, 100.0, 10.0, 20.0, 5.0
    )
    context = system.CreateDefaultContext()
    system.plant_state.FixValue(context, arm.state)
    system.projector.FixValue(context, arm.terms.null_space.ravel())
    system.gravity.FixValue(context, arm.terms.joint_gravity)
    # At the nominal pose and orientation, at rest, only the null-space share of gravity is left.
    np.testing.assert_allclose(
        system.get_output_port().Eval(context),
        arm.terms.null_space @ arm.terms.joint_gravity,
        atol=1e-9,
    )
