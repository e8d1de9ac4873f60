"""hlcmp_drake.systems.environment: the 1-DOF world's unilateral spring."""

import numpy as np
import pytest

from hlcmp_drake.systems.environment import UnilateralSpring, unilateral_spring_force


def test_unilateral_spring_pushes_only_inside():
    spring = UnilateralSpring(surface=0.0, stiffness=10.0)
    context = spring.CreateDefaultContext()
    spring.plant_state.FixValue(context, [-0.15, 0.0])
    np.testing.assert_allclose(spring.GetOutputPort("reaction_force").Eval(context), [1.5])
    spring.plant_state.FixValue(context, [0.2, 0.0])
    np.testing.assert_allclose(spring.GetOutputPort("generalized_force").Eval(context), [0.0])


@pytest.mark.parametrize("surface", [0.0, 0.037, -1.3])
def test_the_system_is_the_equation_to_the_bit(surface):
    """Drake's systems compute k (surface - q) clamped at 0 with the same floating-point
    operations as `unilateral_spring_force`, on both sides of the surface and at any
    velocity."""
    spring = UnilateralSpring(surface=surface, stiffness=12.5)
    context = spring.CreateDefaultContext()
    rng = np.random.default_rng(4)
    for q in [surface, *(surface + rng.uniform(-0.5, 0.5, 40))]:
        spring.plant_state.FixValue(context, [q, rng.normal(scale=3.0)])
        expected = unilateral_spring_force(q, surface, 12.5)
        for port in ("generalized_force", "reaction_force"):
            assert spring.GetOutputPort(port).Eval(context)[0] == expected
