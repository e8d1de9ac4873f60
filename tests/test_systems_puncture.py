"""hlcmp_drake.systems.puncture: HoleFriction's friction starts one step after the tear."""

import numpy as np
import pytest

from hlcmp_drake.systems.puncture import HoleFriction


def test_hole_friction_starts_one_step_after_the_tear():
    from pydrake.multibody.plant import MultibodyPlant
    from pydrake.multibody.tree import PrismaticJoint, SpatialInertia, UnitInertia
    from pydrake.systems.analysis import Simulator

    plant = MultibodyPlant(0.0)  # a tool point on a vertical slide: its state is (z, z')
    tool = plant.AddRigidBody(
        "tool", SpatialInertia(1.0, np.zeros(3), UnitInertia.SolidSphere(0.01))
    )
    plant.AddJoint(PrismaticJoint("slide", plant.world_frame(), tool.body_frame(), [0.0, 0.0, 1.0]))
    plant.Finalize()
    system = HoleFriction(
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
