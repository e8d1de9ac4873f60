"""Each Drake system alone: ports, state sizes, derivatives against the numpy formulas."""

import numpy as np
import pytest
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable

from hlcmp_drake.core.adaptation import adaptation_rates, compliant_profiles
from hlcmp_drake.core.dmp import Dmp, basis_centers_and_widths, normalized_basis
from hlcmp_drake.core.laws import HlcmpGains
from hlcmp_drake.systems.baselines import ConstantImpedanceController, VariableImpedanceController
from hlcmp_drake.systems.environment import UnilateralSpring
from hlcmp_drake.systems.hlcmp_controller import HlcmpController
from hlcmp_drake.systems.references import DmpSource, StepReference
from hlcmp_drake.systems.task_space import TaskForceToJointTorque, TaskSpaceDynamics

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


def _fix_inputs(system, context, m, x, xdot, xd, xd_dot, xd_ddot, s, inertia, coriolis, gravity):
    values = dict(
        position=x,
        velocity=xdot,
        desired_position=xd,
        desired_velocity=xd_dot,
        desired_acceleration=xd_ddot,
        phase=[s],
        task_inertia=np.ravel(inertia),
        task_coriolis=np.ravel(coriolis),
        task_gravity=gravity,
    )
    for name, value in values.items():
        system.GetInputPort(name).FixValue(context, value)


def test_dmp_source_state_ports_and_derivatives(smooth_demo):
    t, positions = smooth_demo
    dmp = Dmp.fit(t, positions, "xyz")
    source = DmpSource(dmp)
    context = source.CreateDefaultContext()
    assert context.num_continuous_states() == 7
    assert [source.get_output_port(i).get_name() for i in range(source.num_output_ports())] == [
        "desired_position",
        "desired_velocity",
        "desired_acceleration",
        "phase",
    ]
    state = np.array([0.1, 0.2, 0.3, 0.5, -0.4, 0.2, 0.6])
    context.SetContinuousState(state)
    pdot, zdot, sdot = dmp.rates(state[:3], state[3:6], state[6])
    derivatives = source.EvalTimeDerivatives(context).CopyToVector()
    np.testing.assert_allclose(derivatives, np.concatenate([pdot, zdot, [sdot]]))
    np.testing.assert_allclose(
        source.GetOutputPort("desired_velocity").Eval(context), state[3:6] / dmp.tau
    )
    np.testing.assert_allclose(
        source.GetOutputPort("desired_acceleration").Eval(context), zdot / dmp.tau
    )
    np.testing.assert_allclose(source.GetOutputPort("phase").Eval(context), [0.6])


def test_dmp_source_simulated_matches_numpy_rollout(smooth_demo):
    from pydrake.systems.analysis import Simulator

    t, positions = smooth_demo
    dmp = Dmp.fit(t, positions, "xyz")
    source = DmpSource(dmp, tau=1.5 * dmp.tau)
    simulator = Simulator(source)
    simulator.get_mutable_integrator().set_target_accuracy(1e-8)
    simulator.AdvanceTo(1.5 * dmp.tau)
    _, p, *_ = dmp.rollout(dt=0.001, tau=1.5 * dmp.tau)
    np.testing.assert_allclose(
        source.GetOutputPort("desired_position").Eval(simulator.get_context()), p[-1], atol=1e-5
    )


def test_step_reference_switches_and_decays_phase():
    ref = StepReference([0.0, 10.0], [[-0.15], [0.0]], tau=20.0, alpha_s=4.0)
    context = ref.CreateDefaultContext()
    context.SetTime(9.9)
    assert ref.GetOutputPort("desired_position").Eval(context)[0] == -0.15
    context.SetTime(10.0)
    assert ref.GetOutputPort("desired_position").Eval(context)[0] == 0.0
    assert ref.GetOutputPort("desired_velocity").Eval(context)[0] == 0.0
    context.SetContinuousState([0.5])
    np.testing.assert_allclose(ref.EvalTimeDerivatives(context).CopyToVector(), [-4.0 * 0.5 / 20.0])


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
    controller = HlcmpController(centers, widths, gains, theta0)
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
    _fix_inputs(controller, context, 2, **inputs)
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
    controller = ConstantImpedanceController([500.0], [40.0], pi=2.0, gain_l=[3.0])
    context = controller.CreateDefaultContext()
    _fix_inputs(
        controller, context, 1, [0.1], [0.2], [0.0], [0.0], [0.0], 1.0, [[5.0]], [[0.0]], [1.0]
    )
    e, edot, eps = 0.1, 0.2, 0.2 + 0.2
    expected = 5.0 * (0.0 - 2.0 * edot) + 1.0 - 3.0 * eps - (500 * e + 40 * edot)
    np.testing.assert_allclose(controller.GetOutputPort("force").Eval(context), [expected])
    assert context.num_continuous_states() == 0


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
    _fix_inputs(vic, context, 1, [0.0], [0.0], [-0.15], [0.0], [0.0], 1.0, [[5.0]], [[0.0]], [0.0])
    vic.external_force.FixValue(context, [0.5])  # less than desired: press on
    derivatives = vic.EvalTimeDerivatives(context).CopyToVector()
    # x_c'' = (-(1.5 - 0.5) - 10 (0 + 0)) / 1 with zero stiffness while tracking force
    np.testing.assert_allclose(derivatives, [0.0, -1.0])
    discrete = vic.EvalUniquePeriodicDiscreteUpdate(context)
    np.testing.assert_allclose(discrete.get_vector(0).CopyToVector(), [0.01 * 1.0 / 10.0])
    # force output: inverse-dynamics PD on x_c, measured force cancelled
    np.testing.assert_allclose(vic.GetOutputPort("force").Eval(context), [5.0 * -1.0 - 0.5])


def test_unilateral_spring_pushes_only_inside():
    spring = UnilateralSpring(surface=0.0, stiffness=10.0)
    context = spring.CreateDefaultContext()
    spring.plant_state.FixValue(context, [-0.15, 0.0])
    np.testing.assert_allclose(spring.GetOutputPort("reaction_force").Eval(context), [1.5])
    spring.plant_state.FixValue(context, [0.2, 0.0])
    np.testing.assert_allclose(spring.GetOutputPort("generalized_force").Eval(context), [0.0])


def test_force_to_torque_saturates():
    torque_map = TaskForceToJointTorque(2, [10.0, 10.0, 1.0])
    context = torque_map.CreateDefaultContext()
    torque_map.force.FixValue(context, [2.0, 3.0])
    torque_map.jacobian.FixValue(context, [1, 0, 1, 0, 1, 1])
    np.testing.assert_allclose(
        torque_map.GetOutputPort("joint_torque").Eval(context), [2.0, 3.0, 1.0]
    )
    np.testing.assert_allclose(torque_map.GetOutputPort("saturated").Eval(context), [1])


DOUBLE_PENDULUM = """<?xml version="1.0"?>
<sdf version="1.9"><model name="pendulum">
  <link name="l1"><pose>0 0 0 0 0 0</pose><inertial><pose>0 0 -0.3 0 0 0</pose><mass>2</mass>
    <inertia><ixx>0.05</ixx><iyy>0.06</iyy><izz>0.01</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia></inertial></link>
  <link name="l2"><pose>0 0 -0.6 0 0 0</pose><inertial><pose>0 0 -0.25 0 0 0</pose><mass>1</mass>
    <inertia><ixx>0.02</ixx><iyy>0.03</iyy><izz>0.01</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia></inertial></link>
  <link name="l3"><pose>0 0 -1.1 0 0 0</pose><inertial><mass>0.5</mass>
    <inertia><ixx>0.01</ixx><iyy>0.01</iyy><izz>0.01</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia></inertial></link>
  <joint name="j1" type="revolute"><parent>world</parent><child>l1</child>
    <axis><xyz>0 1 0</xyz></axis></joint>
  <joint name="j2" type="revolute"><parent>l1</parent><child>l2</child>
    <axis><xyz>1 0 0</xyz></axis></joint>
  <joint name="j3" type="revolute"><parent>l2</parent><child>l3</child>
    <axis><xyz>0 1 0</xyz></axis></joint>
</model></sdf>"""


def test_task_space_dynamics_against_drake_and_finite_differences():
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModelsFromString(DOUBLE_PENDULUM, "sdf")
    plant.Finalize()
    frame, point = plant.GetBodyByName("l3").body_frame(), np.array([0.0, 0.0, -0.1])
    system = TaskSpaceDynamics(plant, frame, point, axes=[0, 2])
    context = system.CreateDefaultContext()
    q, v = np.array([0.4, -0.3, 0.7]), np.array([0.5, -1.2, 0.8])
    system.plant_state.FixValue(context, np.concatenate([q, v]))
    terms = system.terms(context)
    plant_context = plant.CreateDefaultContext()
    plant.SetPositions(plant_context, q)
    plant.SetVelocities(plant_context, v)
    world = plant.world_frame()

    def jacobian_at(qq):
        plant.SetPositions(plant_context, qq)
        return plant.CalcJacobianTranslationalVelocity(
            plant_context, JacobianWrtVariable.kV, frame, point.reshape(3, 1), world, world
        )[[0, 2]]

    jac = jacobian_at(q)
    np.testing.assert_allclose(terms.jacobian, jac)
    np.testing.assert_allclose(terms.velocity, jac @ v)
    mass = plant.CalcMassMatrix(plant_context)
    np.testing.assert_allclose(terms.inertia, np.linalg.inv(jac @ np.linalg.solve(mass, jac.T)))
    # Jdot by central differences along v; C(q, v) from Christoffel symbols by finite
    # differences of M(q): both must agree with the polarization inside the system.
    h = 1e-6
    jdot = (jacobian_at(q + h * v) - jacobian_at(q - h * v)) / (2 * h)

    def mass_at(qq):
        plant.SetPositions(plant_context, qq)
        return plant.CalcMassMatrix(plant_context)

    dm = [
        (mass_at(q + h * np.eye(3)[k]) - mass_at(q - h * np.eye(3)[k])) / (2 * h) for k in range(3)
    ]
    coriolis_q = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            coriolis_q[i, j] = sum(
                0.5 * (dm[k][i, j] + dm[j][i, k] - dm[i][j, k]) * v[k] for k in range(3)
            )
    plant.SetPositions(plant_context, q)
    jbar = np.linalg.solve(mass, jac.T) @ terms.inertia
    expected = jbar.T @ coriolis_q @ jbar - terms.inertia @ jdot @ jbar
    np.testing.assert_allclose(terms.coriolis, expected, atol=1e-6)
    gravity = -plant.CalcGravityGeneralizedForces(plant_context)
    np.testing.assert_allclose(terms.gravity, jbar.T @ gravity)
