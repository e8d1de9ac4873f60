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


def test_the_law_of_the_fast_path_gives_the_systems_force_rates_and_phi():
    """VariableImpedanceLaw (the one-call loop's) against VariableImpedanceController (the
    modular system) at the same instant, tracking a force and free: the same force, x_c'
    and x_c'', and Φ's rate times λ is the system's discrete update of Φ."""
    from hlcmp_drake.core.laws import TaskSpaceInstant, VariableImpedanceLaw

    gains = dict(mass=[1.0], damping=[10.0], free_stiffness=[25.0], sigma=0.01, sample_period=0.001)
    schedule = lambda t: np.array([1.5 if t < 10 else 0.0])  # noqa: E731
    law = VariableImpedanceLaw(**gains, kp=[400.0], kv=[40.0], desired_force=schedule)
    vic = VariableImpedanceController(
        **gains, kp=[400.0], kv=[40.0], desired_force=schedule, initial_position=[0.0]
    )
    for time, state in [(2.0, [0.01, -0.2, 0.03]), (12.0, [-0.05, 0.1, 0.02])]:
        context = vic.CreateDefaultContext()
        context.SetTime(time)
        context.SetContinuousState(state[:2])
        context.SetDiscreteState(0, state[2:])
        inputs = ([0.02], [0.1], [-0.15], [0.01], [0.2], 0.5, [[5.0]], [[0.0]], [0.3])
        fix_inputs(vic, context, 1, *inputs)
        vic.external_force.FixValue(context, [0.4])
        x, xdot, xd, xd_dot, xd_ddot, phase, inertia, coriolis, gravity = inputs
        now = TaskSpaceInstant(
            *map(np.array, (x, xdot, xd, xd_dot, xd_ddot)),
            phase,
            *map(np.array, (inertia, coriolis, gravity)),
            time,
            np.array([0.4]),
        )
        out = law.command(now, np.array(state))
        np.testing.assert_allclose(out.force, vic.GetOutputPort("force").Eval(context))
        rates = out.rates
        np.testing.assert_allclose(rates[:2], vic.EvalTimeDerivatives(context).CopyToVector())
        phi = vic.EvalUniquePeriodicDiscreteUpdate(context).get_vector(0).CopyToVector()
        np.testing.assert_allclose(state[2] + 0.001 * rates[2], phi, rtol=1e-12)
    assert law.theta_size == 3 and list(law.initial_state([0.2])) == [0.2, 0.0, 0.0]
