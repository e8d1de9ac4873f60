"""hlcmp_drake.systems.puncture: HoleFriction's friction starts one step after the tear, an
update that changes nothing says so, and only a tool point that came in through the top face
tears the foam."""

import numpy as np
import pytest

from hlcmp_drake.systems.puncture import HoleFriction


def _tool_on_a_slide(footprint=None):
    """HoleFriction of a tool point on a vertical slide at x = y = 0 (its plant state is
    (z, z')) under a 30 mm foam whose top face is at z = 0.33 m, its frame at x = 0.6 m,
    torn at 15 mm, 150 N/m; the face's extent `footprint` (None: unbounded)."""
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import PrismaticJoint, SpatialInertia, UnitInertia

    plant = MultibodyPlant(0.0)
    tool = plant.AddRigidBody(
        "tool", SpatialInertia(1.0, np.zeros(3), UnitInertia.SolidSphere(0.01))
    )
    plant.AddJoint(PrismaticJoint("slide", plant.world_frame(), tool.body_frame(), [0.0, 0.0, 1.0]))
    plant.Finalize()
    return HoleFriction(
        plant,
        tool.body_frame(),
        [0, 0, -1],
        [0.6, 0, 0.33],
        [0, 0, 1],
        np.eye(3),
        footprint,
        0.03,
        0.015,
        150.0,
        0.002,
        0.001,
    )


def _came_in_from_above(system, context):
    """The update at t = 0 with the tool point 10 mm above the top face (z = 0.33 m): from
    there it comes in through the face. Returns the Simulator at t = 0.5 ms."""
    from pydrake.systems.analysis import Simulator

    system.plant_state.FixValue(context, [0.34, -0.03])
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.0005)
    return simulator


def test_hole_friction_starts_one_step_after_the_tear():
    system = _tool_on_a_slide()
    context = system.CreateDefaultContext()
    simulator = _came_in_from_above(system, context)
    system.plant_state.FixValue(context, [0.31, -0.03])  # 20 mm below the top face, going in
    force = system.GetOutputPort("force")
    stages = []
    for k in range(3):  # one update per millisecond, at t = 1, 2, 3 ms
        simulator.AdvanceTo(0.0015 + 0.001 * k)
        stages.append((system.punctured(context), force.Eval(context)[2]))
    assert stages[0] == (True, 0.0)  # torn at once: the contact is to end now, no friction yet
    assert stages[1] == (True, 0.0)  # one step for the contact to end
    assert stages[2][0] and stages[2][1] == pytest.approx(
        3.0, rel=1e-6
    )  # then 150 N/m x 20 mm, upwards
    system.plant_state.FixValue(context, [0.35, 0.03])  # out of the hole, going up: no friction
    simulator.AdvanceTo(0.0045)
    assert force.Eval(context)[2] == 0.0 and system.punctured(context)


def test_an_update_that_changes_nothing_says_so():
    """Before the tear the state stays as it is at most steps: the update returns
    DidNothing then, so that the Simulator does not write the diagram's state back."""
    from pydrake.systems.framework import EventStatus

    system = _tool_on_a_slide()
    context = system.CreateDefaultContext()
    state = context.get_mutable_state()

    def update_at(z, z_rate):
        system.plant_state.FixValue(context, [z, z_rate])
        return system._update(context, state).severity()

    assert update_at(0.40, -0.03) == EventStatus.Severity.kSucceeded  # above it: comes in
    assert update_at(0.40, -0.03) == EventStatus.Severity.kDidNothing  # still above the foam
    assert update_at(0.32, -0.03) == EventStatus.Severity.kDidNothing  # in, not yet torn
    assert update_at(0.31, 0.03) == EventStatus.Severity.kDidNothing  # deep, coming out
    assert not system.punctured(context)
    assert update_at(0.31, -0.03) == EventStatus.Severity.kSucceeded  # tears: stage 0 -> 1
    assert system.punctured(context)


def test_a_tool_point_started_at_the_face_tears_the_foam():
    """Started 0.1 mm below the face (the inverse kinematics' tolerance under a reference
    starting on it), then down to 20 mm, going in: it came in through the face."""
    from pydrake.systems.analysis import Simulator

    system = _tool_on_a_slide()
    context = system.CreateDefaultContext()
    system.plant_state.FixValue(context, [0.3299, -0.03])
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.0005)
    system.plant_state.FixValue(context, [0.31, -0.03])
    simulator.AdvanceTo(0.0015)
    assert system.punctured(context)


@pytest.mark.parametrize("start_z", [0.31, 0.20])  # in the foam; under it
def test_a_tool_point_that_starts_below_the_top_face_tears_nothing(start_z):
    """Over the face, deep and going in, but never above the face: it never came in
    through it, so the foam neither tears nor rubs, however long it goes on."""
    from pydrake.systems.analysis import Simulator

    system = _tool_on_a_slide()
    context = system.CreateDefaultContext()
    system.plant_state.FixValue(context, [start_z, -0.03])
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.0055)
    assert not system.punctured(context)
    assert system.GetOutputPort("force").Eval(context)[2] == 0.0


@pytest.mark.parametrize(
    "footprint, beside",
    [
        ((np.array([-0.15, -0.1]), np.array([0.15, 0.1])), True),  # the plank ends at x = 0.45
        ((np.array([-0.7, -0.1]), np.array([0.15, 0.1])), False),  # reaching x = -0.1
    ],
)
def test_a_tool_point_beside_the_object_tears_and_rubs_nothing(footprint, beside):
    """Come down from above the face's plane to 20 mm below it, going in: torn only when
    the point is over the face; after the tear, out of the face sideways there is no
    friction."""
    system = _tool_on_a_slide(footprint)
    context = system.CreateDefaultContext()
    simulator = _came_in_from_above(system, context)
    system.plant_state.FixValue(context, [0.31, -0.03])
    simulator.AdvanceTo(0.0035)
    assert system.punctured(context) is not beside
    force = system.GetOutputPort("force").Eval(context)[2]
    assert force == (0.0 if beside else pytest.approx(3.0, rel=1e-6))


def test_over_the_face_reads_the_faces_own_axes():
    from hlcmp_drake.core.puncture import over_the_face

    turned = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90 deg about z
    lower, upper = np.array([-0.15, -0.1]), np.array([0.15, 0.1])
    top = np.array([1.0, 0.0, 0.5])
    assert over_the_face(top + [0.05, 0.12, -0.2], top, turned, lower, upper)
    assert not over_the_face(top + [0.12, 0.05, -0.2], top, turned, lower, upper)
