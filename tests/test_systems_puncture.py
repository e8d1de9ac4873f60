"""hlcmp_drake.systems.puncture: HoleFriction's friction starts one step after the tear, and an
update that changes nothing says so."""

import numpy as np
import pytest

from hlcmp_drake.systems.puncture import HoleFriction


def _tool_on_a_slide():
    """HoleFriction of a tool point on a vertical slide (its plant state is (z, z')) under a
    30 mm foam whose top face is at z = 0.33 m, torn at 15 mm, 150 N/m."""
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
        0.03,
        0.015,
        150.0,
        0.002,
        0.001,
    )


def test_hole_friction_starts_one_step_after_the_tear():
    from pydrake.systems.analysis import Simulator

    system = _tool_on_a_slide()
    context = system.CreateDefaultContext()
    system.plant_state.FixValue(
        context, [0.31, -0.03]
    )  # 20 mm below the top face (z = 0.33), going in
    simulator = Simulator(system, context)
    force = system.GetOutputPort("force")
    stages = []
    for k in range(3):  # one update per millisecond, at t = 0, 1, 2 ms
        simulator.AdvanceTo(0.0005 + 0.001 * k)
        stages.append((system.punctured(context), force.Eval(context)[2]))
    assert stages[0] == (True, 0.0)  # torn at once: the contact is to end now, no friction yet
    assert stages[1] == (True, 0.0)  # one step for the contact to end
    assert stages[2][0] and stages[2][1] == pytest.approx(
        3.0, rel=1e-6
    )  # then 150 N/m x 20 mm, upwards
    system.plant_state.FixValue(context, [0.35, 0.03])  # out of the hole, going up: no friction
    simulator.AdvanceTo(0.0035)
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

    assert update_at(0.40, -0.03) == EventStatus.Severity.kDidNothing  # above the foam
    assert update_at(0.32, -0.03) == EventStatus.Severity.kDidNothing  # in, not yet torn
    assert update_at(0.31, 0.03) == EventStatus.Severity.kDidNothing  # deep, coming out
    assert not system.punctured(context)
    assert update_at(0.31, -0.03) == EventStatus.Severity.kSucceeded  # tears: stage 0 -> 1
    assert system.punctured(context)
