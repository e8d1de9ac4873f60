"""hlcmp_drake.systems.arm: the torque below the task (NullSpaceImpedance) and the wrist force
sensor (ToolContactForce)."""

import numpy as np

from hlcmp_drake.systems.arm import NullSpaceImpedance


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
