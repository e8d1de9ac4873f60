"""hlcmp_drake.systems.baselines: the force-tracking variable impedance alone."""

import numpy as np
from conftest import fix_inputs

from hlcmp_drake.systems.baselines import VariableImpedanceController


def test_variable_impedance_controller_state_and_phi_update():
    vic = VariableImpedanceController(
        mass=[1.0],
        damping=[10.0],
        free_stiffness=[25.0],
        sigma=0.01,
        sample_period=0.001,
        kp=[400.0],
        kv=[40.0],
        desired_force=lambda t: np.array([1.5 if t < 10 else 0.0]),
        initial_position=[0.0],
    )
    context = vic.CreateDefaultContext()
    assert context.num_continuous_states() == 2
    assert context.num_discrete_state_groups() == 1
    fix_inputs(vic, context, 1, [0.0], [0.0], [-0.15], [0.0], [0.0], 1.0, [[5.0]], [[0.0]], [0.0])
    vic.external_force.FixValue(context, [0.5])  # less than desired: press on
    derivatives = vic.EvalTimeDerivatives(context).CopyToVector()
    # x_c'' = (-(1.5 - 0.5) - 10 (0 + 0)) / 1 with zero stiffness while tracking force
    np.testing.assert_allclose(derivatives, [0.0, -1.0])
    discrete = vic.EvalUniquePeriodicDiscreteUpdate(context)
    np.testing.assert_allclose(discrete.get_vector(0).CopyToVector(), [0.01 * 1.0 / 10.0])
    # force output: inverse-dynamics PD on x_c, measured force cancelled
    np.testing.assert_allclose(vic.GetOutputPort("force").Eval(context), [5.0 * -1.0 - 0.5])
