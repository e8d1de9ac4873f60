"""hlcmp_drake.systems.arm: the torque below the task (NullSpaceImpedance) and the wrist force
sensor (ToolContactForce)."""

import numpy as np
import pytest
from pydrake.geometry import (
    AddCompliantHydroelasticProperties,
    AddContactMaterial,
    AddRigidHydroelasticProperties,
    Box,
    ProximityProperties,
    Sphere,
)
from pydrake.math import RigidTransform
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    CoulombFriction,
    MultibodyPlant,
    MultibodyPlantConfig,
)
from pydrake.multibody.tree import FixedOffsetFrame, PrismaticJoint, SpatialInertia, UnitInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, PortDataType
from pydrake.systems.primitives import ConstantVectorSource

from hlcmp_drake.systems.arm import NullSpaceImpedance, ToolContactForce


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


# --- ToolContactForce -------------------------------------------------------------------

RADIUS = 0.05  # [m], of the three balls


def _ball_stack(contact_model, applied_force=None, side_offset=None):
    """Two balls (3 kg below, 1 kg on top) stacked on a rigid floor, each on a vertical
    slide, and a third ball on a horizontal slide off the floor that touches nothing; a
    ToolContactForce on each ball and one on the world (the floor); with `side_offset`
    (3,) [m], one more, "lower_side", on a frame of the lower ball that far from its centre.
    Returns the diagram, the plant, {name: (sensor, mass)} and {name: starting slide
    position}."""
    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlant(
        MultibodyPlantConfig(time_step=1e-3, contact_model=contact_model), builder
    )

    def proximity(rigid):
        properties = ProximityProperties()
        AddContactMaterial(
            dissipation=5.0, friction=CoulombFriction(0.5, 0.5), properties=properties
        )
        if rigid:
            AddRigidHydroelasticProperties(properties=properties)
        else:
            AddCompliantHydroelasticProperties(
                resolution_hint=0.02, hydroelastic_modulus=1e6, properties=properties
            )
        return properties

    plant.RegisterCollisionGeometry(
        plant.world_body(), RigidTransform([0, 0, -0.05]), Box(1, 1, 0.1), "floor", proximity(True)
    )
    balls, start = {}, {}
    for name, mass, axis, q0 in (
        ("lower", 3.0, [0, 0, 1], RADIUS),  # resting on the floor (its top face is z = 0)
        ("upper", 1.0, [0, 0, 1], 3 * RADIUS),  # resting on the lower ball
        ("apart", 1.0, [1, 0, 0], 1.0),  # 1 m along x: beyond the floor's edge, at z = 0
    ):
        body = plant.AddRigidBody(
            name, SpatialInertia(mass, np.zeros(3), UnitInertia.SolidSphere(RADIUS))
        )
        plant.RegisterCollisionGeometry(
            body, RigidTransform(), Sphere(RADIUS), name, proximity(False)
        )
        plant.AddJoint(PrismaticJoint(name, plant.world_frame(), body.body_frame(), axis))
        balls[name] = (body.body_frame(), mass)
        start[name] = q0
    frames = [*balls.items(), ("floor", (plant.world_body().body_frame(), None))]
    if side_offset is not None:
        side = plant.AddFrame(
            FixedOffsetFrame("lower_side", balls["lower"][0], RigidTransform(side_offset))
        )
        frames.append(("lower_side", (side, None)))
    plant.Finalize()
    sensors = {}
    for name, (frame, mass) in frames:
        with_applied = applied_force is not None and name == "upper"
        sensor = builder.AddSystem(
            ToolContactForce(plant, frame, axes=(0, 2), applied_force=with_applied)
        )
        builder.Connect(plant.get_contact_results_output_port(), sensor.contact_results)
        builder.Connect(plant.get_body_poses_output_port(), sensor.body_poses)
        if with_applied:
            source = builder.AddSystem(ConstantVectorSource(applied_force))
            builder.Connect(source.get_output_port(), sensor.applied_force)
        sensors[name] = (sensor, mass)
    return builder.Build(), plant, sensors, start


def _settled(contact_model, applied_force=None, seconds=1.0, side_offset=None):
    """The ball stack after `seconds` (at rest): (plant, its context, {name: (sensor, its
    context, mass)})."""
    diagram, plant, sensors, start = _ball_stack(contact_model, applied_force, side_offset)
    simulator = Simulator(diagram)
    root = simulator.get_mutable_context()
    plant_context = plant.GetMyMutableContextFromRoot(root)
    for name, q0 in start.items():
        plant.GetJointByName(name).set_translation(plant_context, q0)
    simulator.AdvanceTo(seconds)
    return (
        plant,
        plant_context,
        {
            name: (sensor, sensor.GetMyContextFromRoot(root), mass)
            for name, (sensor, mass) in sensors.items()
        },
    )


def test_tool_contact_force_ports():
    plant = MultibodyPlant(0.001)
    body = plant.AddRigidBody(
        "tool", SpatialInertia(1.0, np.zeros(3), UnitInertia.SolidSphere(0.1))
    )
    plant.Finalize()
    for axes, applied in (((0, 1, 2), False), ((2,), True), ((0, 2), False)):
        sensor = ToolContactForce(plant, body.body_frame(), axes=axes, applied_force=applied)
        assert sensor.contact_results.get_name() == "contact_results"
        assert sensor.contact_results.get_data_type() == PortDataType.kAbstractValued
        assert sensor.body_poses.get_data_type() == PortDataType.kAbstractValued
        assert sensor.num_input_ports() == (3 if applied else 2)
        if applied:
            assert sensor.applied_force.get_name() == "applied_force"
            assert sensor.applied_force.size() == 3
        else:
            assert sensor.applied_force is None
        outputs = [sensor.get_output_port(i) for i in range(sensor.num_output_ports())]
        assert [(p.get_name(), p.size()) for p in outputs] == [
            ("force", 3),
            ("task_force", len(axes)),
            ("torque", 3),
        ]


@pytest.mark.parametrize("contact_model", ["point", "hydroelastic_with_fallback"])
def test_tool_contact_torque_is_about_the_tool_point(contact_model):
    """The lower ball at rest: its two contacts (the floor below, the upper ball above) act
    on the vertical through its centre and sum to m_l g upwards, so about the centre their
    torque is 0, and about a point d from the centre it is (-d) x (m_l g up): the lever
    arms are the contact points' from the tool point, not the body's origin."""
    offset = np.array([0.02, -0.01, 0.03])
    plant, _, sensors = _settled(contact_model, side_offset=offset)
    g = plant.gravity_field().gravity_vector()
    weight = sensors["lower"][2]
    centre, centre_context, _ = sensors["lower"]
    np.testing.assert_allclose(centre.GetOutputPort("torque").Eval(centre_context), 0.0, atol=1e-4)
    side, side_context, _ = sensors["lower_side"]
    np.testing.assert_allclose(
        side.GetOutputPort("torque").Eval(side_context),
        np.cross(-offset, -weight * g),
        rtol=1e-3,
        atol=1e-5,
    )


@pytest.mark.parametrize(
    "contact_model, kind",
    [("point", "point_pair"), ("hydroelastic_with_fallback", "hydroelastic")],
)
def test_tool_contact_force_reads_the_weight_a_stack_rests_with(contact_model, kind):
    """At rest each ball's contact forces carry its own weight: the upper ball's one contact
    pushes it up by m_u g, the lower ball's two (the floor up by (m_l + m_u) g, the upper
    ball down by m_u g) sum to m_l g, and the floor is pushed down by both weights. Each
    ball is body A of one contact pair and body B of another, or the two balls take
    different sides: either way both of the sensor's sign branches are read."""
    plant, plant_context, sensors = _settled(contact_model)
    results = plant.get_contact_results_output_port().Eval(plant_context)
    counts = {
        "point_pair": results.num_point_pair_contacts(),
        "hydroelastic": results.num_hydroelastic_contacts(),
    }
    assert counts.pop(kind) == 2 and set(counts.values()) == {0}  # floor-lower, lower-upper
    g = plant.gravity_field().gravity_vector()  # (0, 0, -9.81)
    np.testing.assert_allclose(np.abs(plant.GetVelocities(plant_context)), 0.0, atol=1e-5)
    weights = {name: mass for name, (_, _, mass) in sensors.items() if mass}
    expected = {
        "lower": -weights["lower"] * g,
        "upper": -weights["upper"] * g,
        "apart": np.zeros(3),  # nothing touches it
        "floor": (weights["lower"] + weights["upper"]) * g,
    }
    for name, (sensor, context, _) in sensors.items():
        force = sensor.GetOutputPort("force").Eval(context)
        np.testing.assert_allclose(force, expected[name], rtol=1e-3, atol=1e-6, err_msg=name)
        np.testing.assert_array_equal(
            sensor.GetOutputPort("task_force").Eval(context), force[[0, 2]]
        )
        np.testing.assert_array_equal(sensor.force_on_tool(context), force)


def test_tool_contact_force_adds_the_applied_force():
    """A force the world applies other than by contact (a torn hole's friction) is read on
    top of the contact force; the plant itself is not pushed by it."""
    applied = np.array([0.5, -2.0, 3.0])
    plant, plant_context, sensors = _settled("point", applied_force=applied)
    g = plant.gravity_field().gravity_vector()
    sensor, context, mass = sensors["upper"]
    np.testing.assert_allclose(
        sensor.GetOutputPort("force").Eval(context), -mass * g + applied, rtol=1e-3, atol=1e-6
    )
    np.testing.assert_allclose(
        sensor.GetOutputPort("task_force").Eval(context), (-mass * g + applied)[[0, 2]], rtol=1e-3
    )
    floor, floor_context, _ = sensors["floor"]  # the stack rests as without the extra input
    np.testing.assert_allclose(
        floor.GetOutputPort("force").Eval(floor_context),
        (sensors["lower"][2] + mass) * g,
        rtol=1e-3,
    )
