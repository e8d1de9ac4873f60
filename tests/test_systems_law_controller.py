"""hlcmp_drake.systems.law_controller: a law as one system, alone: the Hl-CMP's ports, state
size, force and rates of theta against the numpy equations; the constant impedance's force."""

import numpy as np
import pytest
from conftest import fix_inputs

from hlcmp_drake.core.adaptation import adaptation_rates, compliant_profiles
from hlcmp_drake.core.dmp import basis_centers_and_widths, normalized_basis
from hlcmp_drake.core.laws import ConstantImpedanceLaw, HlcmpGains, HlcmpLaw
from hlcmp_drake.systems.law_controller import LawController

CONTROLLER_INPUTS = [
    "position",
    "velocity",
    "desired_position",
    "desired_velocity",
    "desired_acceleration",
    "phase",
    "task_inertia",
    "task_coriolis",
    "task_gravity",
]


@pytest.fixture
def hlcmp_setup():
    centers, widths = basis_centers_and_widths(4, 4.0)
    gains = HlcmpGains(
        np.array([3000.0, 100.0]),
        np.array([90.0, 50.0]),
        np.array([9.0, 0.0]),
        2.0,
        np.array([3.0, 1.0]),
    )
    rng = np.random.default_rng(3)
    theta0 = rng.uniform(0, 50, 3 * 2 * 4)
    controller = LawController(HlcmpLaw(centers, widths, gains), theta0)
    context = controller.CreateDefaultContext()
    inputs = dict(
        x=np.array([0.1, 0.2]),
        xdot=np.array([0.05, -0.1]),
        xd=np.array([0.12, 0.15]),
        xd_dot=np.array([0.0, 0.1]),
        xd_ddot=np.array([0.3, 0.0]),
        s=0.4,
        inertia=np.array([[2.0, 0.1], [0.1, 3.0]]),
        coriolis=np.array([[0.0, 0.2], [-0.2, 0.0]]),
        gravity=np.array([1.0, -9.0]),
    )
    fix_inputs(controller, context, 2, **inputs)
    return controller, context, inputs, (centers, widths, gains, theta0)


def test_hlcmp_controller_ports_and_state(hlcmp_setup):
    controller, context, *_ = hlcmp_setup
    assert context.num_continuous_states() == 3 * 2 * 4
    names = [controller.get_input_port(i).get_name() for i in range(controller.num_input_ports())]
    assert names == CONTROLLER_INPUTS
    assert [
        controller.get_output_port(i).get_name() for i in range(controller.num_output_ports())
    ] == ["force", "stiffness", "damping", "feedforward", "impedance_force", "sliding_error"]


def test_hlcmp_controller_matches_the_numpy_equations(hlcmp_setup):
    controller, context, i, (centers, widths, gains, theta0) = hlcmp_setup
    theta_k, theta_d, theta_v = theta0.reshape(3, 2, 4)
    g = normalized_basis(i["s"], centers, widths)
    e, edot = i["x"] - i["xd"], i["xdot"] - i["xd_dot"]
    eps = edot + gains.pi * e
    k, d, v = compliant_profiles(theta_k, theta_d, theta_v, g)
    xe_dot, xe_ddot = i["xd_dot"] - gains.pi * e, i["xd_ddot"] - gains.pi * edot
    f0 = i["inertia"] @ xe_ddot + i["coriolis"] @ xe_dot + i["gravity"] - gains.gain_l * eps
    expected_force = f0 - (k * e + d * edot) - v
    np.testing.assert_allclose(controller.GetOutputPort("force").Eval(context), expected_force)
    np.testing.assert_allclose(controller.GetOutputPort("stiffness").Eval(context), k)
    np.testing.assert_allclose(controller.GetOutputPort("sliding_error").Eval(context), eps)
    rates = adaptation_rates(eps, e, edot, g, gains.q_k, gains.q_d, gains.q_v)
    np.testing.assert_allclose(
        controller.EvalTimeDerivatives(context).CopyToVector(),
        np.concatenate([r.ravel() for r in rates]),
    )
    assert np.all(rates[2][1] == 0)  # Q_v = 0 on axis 1: its feed-forward does not move


def test_hlcmp_theta_still_when_tracking_is_perfect(hlcmp_setup):
    controller, context, i, _ = hlcmp_setup
    controller.GetInputPort("desired_position").FixValue(context, i["x"])
    controller.GetInputPort("desired_velocity").FixValue(context, i["xdot"])
    np.testing.assert_array_equal(controller.EvalTimeDerivatives(context).CopyToVector(), 0.0)


def test_constant_impedance_controller():
    controller = LawController(ConstantImpedanceLaw([500.0], [40.0], pi=2.0, gain_l=[3.0]))
    context = controller.CreateDefaultContext()
    fix_inputs(
        controller, context, 1, [0.1], [0.2], [0.0], [0.0], [0.0], 1.0, [[5.0]], [[0.0]], [1.0]
    )
    e, edot, eps = 0.1, 0.2, 0.2 + 0.2
    expected = 5.0 * (0.0 - 2.0 * edot) + 1.0 - 3.0 * eps - (500 * e + 40 * edot)
    np.testing.assert_allclose(controller.GetOutputPort("force").Eval(context), [expected])
    assert context.num_continuous_states() == 0
