"""hlcmp_drake.systems.environment: the 1-DOF world's unilateral spring."""

import numpy as np

from hlcmp_drake.systems.environment import UnilateralSpring


def test_unilateral_spring_pushes_only_inside():
    spring = UnilateralSpring(surface=0.0, stiffness=10.0)
    context = spring.CreateDefaultContext()
    spring.plant_state.FixValue(context, [-0.15, 0.0])
    np.testing.assert_allclose(spring.GetOutputPort("reaction_force").Eval(context), [1.5])
    spring.plant_state.FixValue(context, [0.2, 0.0])
    np.testing.assert_allclose(spring.GetOutputPort("generalized_force").Eval(context), [0.0])
