"""Our iiwa14 SDF against the reference numbers (shared/reference/iiwa14.md)."""

import re

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable

from hlcmp_drake.io.paths import MODELS_DIR

SDF = (MODELS_DIR / "iiwa14.sdf").read_text()
EFFORT = [320, 320, 176, 176, 110, 40, 40]
VELOCITY = [1.4835298641951802] * 2 + [
    1.7453292519943295,
    1.3089969389957472,
    2.2689280275926285,
    2.356194490192345,
    2.356194490192345,
]
LIMITS = [
    2.96705972839,
    2.09439510239,
    2.96705972839,
    2.09439510239,
    2.96705972839,
    2.09439510239,
    3.05432619099,
]


def _arm(text=SDF):
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(text, "sdf")
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("iiwa_link_0"))
    plant.Finalize()
    return plant, plant.CreateDefaultContext()


def test_mass_and_upright_height():
    plant, context = _arm()
    instance = plant.GetModelInstanceByName("iiwa14")
    assert sum(
        plant.get_body(b).default_mass() for b in plant.GetBodyIndices(instance)
    ) == pytest.approx(30.61)
    link7 = plant.GetFrameByName("iiwa_link_7").CalcPoseInWorld(context).translation()
    np.testing.assert_allclose(link7, [0, 0, 1.261], atol=1e-9)
    flange = plant.GetFrameByName("flange").CalcPoseInWorld(context).translation()
    np.testing.assert_allclose(flange, [0, 0, 1.306], atol=1e-9)


def test_joint_limits_efforts_and_actuators():
    plant, _ = _arm()
    assert plant.num_actuators() == 7
    for i in range(7):
        joint = plant.GetJointByName(f"iiwa_joint_{i + 1}")
        assert joint.position_upper_limits()[0] == pytest.approx(LIMITS[i])
        assert joint.velocity_upper_limits()[0] == pytest.approx(VELOCITY[i])
        assert (
            plant.get_joint_actuator(plant.GetJointActuatorIndices()[i]).effort_limit() == EFFORT[i]
        )


def test_reflected_rotor_inertia_on_the_mass_matrix_diagonal():
    plant, context = _arm()
    bare, bare_context = _arm(
        re.sub(r"<drake:(rotor_inertia|gear_ratio)>[^<]*</drake:\w+>", "", SDF)
    )
    q = np.array([0.3, -0.5, 0.2, -1.2, 0.4, 0.9, -0.3])
    plant.SetPositions(context, q)
    bare.SetPositions(bare_context, q)
    extra = np.diag(plant.CalcMassMatrix(context) - bare.CalcMassMatrix(bare_context))
    np.testing.assert_allclose(extra, [3.3818] * 4 + [1.321, 1.1622, 1.1622], atol=1e-3)


def test_gravity_torques_match_the_sum_over_link_masses():
    """G(q) = -sum_i J_com,i^T m_i g, evaluated link by link, at a bent pose."""
    plant, context = _arm()
    q = np.array([0.4, 0.8, -0.3, -1.1, 0.6, 1.2, 0.2])
    plant.SetPositions(context, q)
    g = plant.gravity_field().gravity_vector()
    expected = np.zeros(7)
    for index in plant.GetBodyIndices(plant.GetModelInstanceByName("iiwa14")):
        body = plant.get_body(index)
        com = body.CalcCenterOfMassInBodyFrame(context).reshape(3, 1)
        jac = plant.CalcJacobianTranslationalVelocity(
            context,
            JacobianWrtVariable.kV,
            body.body_frame(),
            com,
            plant.world_frame(),
            plant.world_frame(),
        )
        expected -= jac.T @ (body.default_mass() * g)
    np.testing.assert_allclose(-plant.CalcGravityGeneralizedForces(context), expected, atol=1e-9)
    # and a number to hold on to: joint 2 carries the most at this pose
    assert np.argmax(np.abs(expected)) == 1 and abs(expected[1]) > 30
