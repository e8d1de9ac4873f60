"""hlcmp_drake.systems.spatial_task_space on the insertion's iiwa: the spatial Jacobian
against finite differences of the tool pose, Lambda's definition and its floor near the
stretched arm, C_x against Christoffel symbols, the translational rows against the 3-D
model, the dynamically consistent null space, and the saturating wrench-to-torque map."""

import numpy as np
import pytest

from hlcmp_drake.core import quaternion as quat
from hlcmp_drake.core.kernels import kernel_chosen, numba_available
from hlcmp_drake.core.operational_space import task_joint_torque
from hlcmp_drake.core.task_inertia import EIGENVALUE_FLOOR, conditioned_task_inertia
from hlcmp_drake.systems.spatial_task_space import SpatialTaskSpaceModel

MOVING = np.array([0.4, -0.7, 0.5, 0.3, -0.2, 0.6, -0.9])  # a joint velocity [rad/s]


@pytest.fixture
def model(arm):
    return SpatialTaskSpaceModel(arm.plant, arm.tip)


def _at_rest(arm, model, q=None):
    q = arm.setup.q0 if q is None else q
    return model.terms(np.concatenate([q, np.zeros(7)]))


def _mass(arm, model):
    return arm.plant.CalcMassMatrix(model.context)


def _acceleration(arm, q, tau):
    context = arm.plant.CreateDefaultContext()
    arm.plant.SetPositions(context, q)
    mass = arm.plant.CalcMassMatrix(context)
    return np.linalg.solve(mass, tau + arm.plant.CalcGravityGeneralizedForces(context))


def test_the_jacobian_is_the_derivative_of_the_tool_pose(arm, model):
    """Rows 0-2: the world angular velocity, from R(q + h e_k) R(q - h e_k)^T; rows 3-5:
    the tool point's velocity, from its positions; angular first, as Drake orders them."""
    q0, h = arm.setup.q0 + 0.1, 1e-6
    jac = model.terms(np.concatenate([q0, MOVING])).jacobian
    for k in range(7):
        step = h * np.eye(7)[k]
        plus, minus = _at_rest(arm, model, q0 + step), _at_rest(arm, model, q0 - step)
        turn = quat.to_rotation_vector(
            quat.multiply(plus.orientation, quat.conjugate(minus.orientation))
        )
        np.testing.assert_allclose(turn / (2 * h), jac[:3, k], atol=1e-8)
        np.testing.assert_allclose(
            (plus.position - minus.position) / (2 * h), jac[3:, k], atol=1e-8
        )
    terms = model.terms(np.concatenate([q0, MOVING]))
    np.testing.assert_allclose(terms.spatial_velocity, jac @ MOVING)


def test_lambda_is_the_inverse_of_the_inverse_task_inertia_at_a_working_pose(arm):
    # numpy's inverse to the bit on the numpy path (the compiled one agrees with it to
    # 1e-12: tests/test_systems_pose_control.py)
    with kernel_chosen("numpy"):
        model = SpatialTaskSpaceModel(arm.plant, arm.tip)
    terms = _at_rest(arm, model)
    jac, mass = terms.jacobian, _mass(arm, model)
    phi = jac @ np.linalg.solve(mass, jac.T)
    assert terms.floored == 0
    np.testing.assert_array_equal(terms.inertia, np.linalg.inv(phi))
    # the margin the docstring of conditioned_task_inertia states: the smallest block-scaled
    # eigenvalue at the insertion's start posture
    scale = np.repeat(1 / np.sqrt([np.trace(phi[:3, :3]) / 3, np.trace(phi[3:, 3:]) / 3]), 3)
    smallest = np.linalg.eigvalsh(scale[:, None] * phi * scale[None, :])[0]
    assert 0.02 < smallest < 0.05 and smallest > 10 * EIGENVALUE_FLOOR


def _near_stretched(angle):
    """The arm bent by `angle` [rad] at joints 2, 4, 6 (all zero is the arm stretched
    upright, singular: no joint moves the tool along the arm)."""
    q = np.zeros(7)
    q[1], q[3], q[5] = angle, -2 * angle, angle
    return q


def test_near_the_stretched_arm_lambda_stays_bounded_and_exact_off_the_singular_directions(
    arm,
):
    # numpy's solve to the bit on the numpy path: there Φ's condition (up to 1e15) amplifies
    # the compiled path's other rounding (it agrees to 1e-12 of scale:
    # tests/test_systems_pose_control.py)
    with kernel_chosen("numpy"):
        model = SpatialTaskSpaceModel(arm.plant, arm.tip)
    compiled = SpatialTaskSpaceModel(arm.plant, arm.tip) if numba_available() else None
    bounds = []
    for angle in (0.03, 0.01, 1e-4, 0.0):
        terms = _at_rest(arm, model, _near_stretched(angle))
        if compiled is not None:
            theirs = _at_rest(arm, compiled, _near_stretched(angle)).inertia
            scale = np.abs(terms.inertia).max()
            np.testing.assert_allclose(theirs, terms.inertia, rtol=0, atol=1e-12 * scale)
        jac, mass = terms.jacobian, _mass(arm, model)
        phi = jac @ np.linalg.solve(mass, jac.T)
        assert np.linalg.cond(phi) > 1e4 and terms.floored >= 1
        inertia, floored = conditioned_task_inertia(phi)
        np.testing.assert_array_equal(inertia, terms.inertia)
        # Lambda Phi is the identity on the directions kept and shrinks the floored ones
        gains = np.sort(np.linalg.eigvals(inertia @ phi).real)
        np.testing.assert_allclose(gains[floored:], 1.0, atol=1e-6)
        assert np.all(gains[:floored] < 1.0)
        bounds.append(np.linalg.norm(terms.inertia, 2))
    scale_bound = 1 / EIGENVALUE_FLOOR * np.max(1 / np.diag(phi)) * 6
    assert max(bounds) < scale_bound
    # the exact inverse at the stretched arm is not even finite in a meaningful sense
    assert np.linalg.cond(phi) > 1e15


def test_the_coriolis_term_against_christoffel_symbols_and_jdot(arm, model):
    q, v, h = arm.setup.q0 + 0.1, MOVING, 1e-6
    terms = model.terms(np.concatenate([q, v]))
    mass, inertia = _mass(arm, model), terms.inertia
    jbar = np.linalg.solve(mass, terms.jacobian.T) @ inertia

    def at(qq):
        t = _at_rest(arm, model, qq)
        return t.jacobian, _mass(arm, model)

    jdot = (at(q + h * v)[0] - at(q - h * v)[0]) / (2 * h)
    dm = [(at(q + h * np.eye(7)[k])[1] - at(q - h * np.eye(7)[k])[1]) / (2 * h) for k in range(7)]
    coriolis_q = np.array(
        [
            [sum(0.5 * (dm[k][i, j] + dm[j][i, k] - dm[i][j, k]) * v[k] for k in range(7))
             for j in range(7)]
            for i in range(7)
        ]
    )  # fmt: skip
    expected = jbar.T @ coriolis_q @ jbar - inertia @ jdot @ jbar
    np.testing.assert_allclose(terms.coriolis, expected, atol=1e-5 * np.abs(expected).max())
    operator = model.terms(np.concatenate([q, v]), coriolis_matrix=False).coriolis
    w = np.array([0.2, -0.1, 0.3, 0.05, -0.02, 0.04])
    np.testing.assert_allclose(operator @ w, terms.coriolis @ w, rtol=1e-9, atol=1e-12)


def test_the_translational_rows_reduce_to_the_3d_task_space_model(arm, model):
    terms, three = _at_rest(arm, model), arm.terms
    np.testing.assert_allclose(terms.position, three.position, atol=1e-15)
    np.testing.assert_allclose(terms.jacobian[3:], three.jacobian, atol=1e-14)
    inverse = np.linalg.inv(terms.inertia)
    np.testing.assert_allclose(inverse[3:, 3:], np.linalg.inv(three.inertia), rtol=1e-10)
    np.testing.assert_allclose(
        (inverse @ terms.gravity)[3:], np.linalg.solve(three.inertia, three.gravity), rtol=1e-9
    )
    # ... but the 6-D Lambda's translational block is not the 3-D Lambda: rotation couples
    assert np.abs(terms.inertia[3:, 3:] - three.inertia).max() > 0.1 * np.abs(three.inertia).max()


def test_a_wrench_gives_the_spatial_acceleration_it_should_against_gravity(arm, model):
    """tau = J^T (F + p) + N^T G at rest: V' = Lambda^-1 F (Eq. 2 in 6-D)."""
    terms = _at_rest(arm, model)
    for wrench in (np.zeros(6), np.array([0.5, -1.0, 2.0, 5.0, -3.0, 10.0])):
        tau = terms.jacobian.T @ (wrench + terms.gravity) + terms.null_space @ terms.joint_gravity
        np.testing.assert_allclose(
            terms.jacobian @ _acceleration(arm, arm.setup.q0, tau),
            np.linalg.solve(terms.inertia, wrench),
            atol=1e-9,
        )


def test_the_null_space_is_the_seventh_joints_and_moves_no_part_of_the_pose(arm, model):
    terms = _at_rest(arm, model)
    projector, mass = terms.null_space, _mass(arm, model)
    np.testing.assert_allclose(projector @ projector, projector, atol=1e-10)
    np.testing.assert_allclose(
        terms.jacobian @ np.linalg.solve(mass, projector), 0.0, atol=1e-10
    )  # J M^-1 N^T = 0: dynamically consistent
    assert np.linalg.matrix_rank(projector, tol=1e-8) == 1
    rng = np.random.default_rng(1)
    for _ in range(3):
        tau = projector @ rng.normal(0, 10, 7) + terms.joint_gravity
        np.testing.assert_allclose(
            terms.jacobian @ _acceleration(arm, arm.setup.q0, tau), 0.0, atol=1e-9
        )


def test_the_wrench_map_adds_the_torque_below_the_task_and_saturates(arm, model):
    """The 6-D tick's map: `task_joint_torque` with the spatial Jacobian."""
    terms = _at_rest(arm, model)
    limits = np.array([320.0, 320, 176, 176, 110, 40, 40])
    below = terms.null_space @ terms.joint_gravity
    wrench = np.array([0.5, -1.0, 2.0, 5.0, -3.0, 10.0])
    torque, saturated = task_joint_torque(terms.jacobian, wrench, below, limits)
    np.testing.assert_allclose(torque, terms.jacobian.T @ wrench + below)
    assert saturated == 0
    torque, saturated = task_joint_torque(terms.jacobian, np.full(6, 1e4), below, limits)
    assert saturated > 0 and np.all(np.abs(torque) <= limits)


def _closed_loop(arm, law, tilt, seconds, theta0=None, tool_torque=(0.0, 0.0, 0.0)):
    """The insertion's iiwa (discrete, 1 ms) held at its start pose by `law` through the
    6-D terms, starting `tilt` (a rotation vector about the tool's axes [rad]) away from
    the desired orientation, with a constant torque `tool_torque` about the tool's axes at
    the start [N m] applied to the tool's body. Returns the last tick's e [m] and e_r
    [rad], and θ."""
    from pydrake.math import RotationMatrix
    from pydrake.multibody.math import SpatialForce
    from pydrake.multibody.parsing import ModelDirectives, Parser, ProcessModelDirectives
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, ExternallyAppliedSpatialForce
    from pydrake.multibody.tree import JointActuatorIndex
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    from hlcmp_drake.core.rotation_law import rotation_errors
    from hlcmp_drake.io.paths import register_package
    from hlcmp_drake.systems.arm import BelowTaskImpedance
    from hlcmp_drake.systems.pose_control import PoseControlTick, PoseReference
    from hlcmp_drake.worlds.models import scoped_frame

    builder = DiagramBuilder()
    plant, _ = AddMultibodyPlantSceneGraph(builder, time_step=1e-3)
    parser = Parser(plant)
    register_package(parser.package_map())
    ProcessModelDirectives(ModelDirectives(directives=arm.scenario.directives), plant, parser)
    plant.Finalize()
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    plant.SetPositions(context, arm.setup.q0)
    limits = np.array(
        [plant.get_joint_actuator(JointActuatorIndex(i)).effort_limit() for i in range(7)]
    )
    model = SpatialTaskSpaceModel(arm.plant, arm.tip)
    posture = BelowTaskImpedance(arm.plant, arm.tip, RotationMatrix(), arm.setup.q0, 0, 0, 20, 5)
    tick = PoseControlTick(model, posture, law, limits)
    start = model.terms(np.concatenate([arm.setup.q0, np.zeros(7)]))
    desired = quat.multiply(start.orientation, quat.from_rotation_vector(-np.asarray(tilt)))
    disturbance = ExternallyAppliedSpatialForce()
    disturbance.body_index = scoped_frame(plant, arm.scenario.task.tool_frame).body().index()
    disturbance.F_Bq_W = SpatialForce(quat.rotate(start.orientation, tool_torque), np.zeros(3))
    plant.get_applied_spatial_force_input_port().FixValue(context, [disturbance])
    theta = np.zeros(law.theta_size) if theta0 is None else np.array(theta0, dtype=float)
    zero, steps = np.zeros(3), round(seconds / 1e-3)
    for k in range(steps):
        reference = PoseReference(start.position, zero, zero, desired, zero, zero, 1.0 - k / steps)
        result = tick.evaluate(plant.GetPositionsAndVelocities(context), reference, theta)
        plant.get_actuation_input_port().FixValue(context, result.torque)
        if result.law.rates is not None:
            theta = theta + 1e-3 * result.law.rates
        simulator.AdvanceTo((k + 1) * 1e-3)
    terms = result.terms
    e_r, _ = rotation_errors(terms.orientation, zero, desired, zero)
    return terms.position - start.position, e_r, theta


def test_the_6d_constant_impedance_turns_the_tool_back_and_holds_its_point(arm):
    from hlcmp_drake.core.rotation_law import PoseImpedance, constant_pose_impedance

    impedance = PoseImpedance(
        np.full(3, 1000.0), np.full(3, 60.0), np.full(3, 200.0), np.full(3, 2.0)
    )
    law = constant_pose_impedance(impedance, 5.0, np.full(3, 10.0), 5.0, np.full(3, 1.0))
    e, e_r, _ = _closed_loop(arm, law, [0.1, 0.0, 0.05], 2.0)
    assert np.linalg.norm(e_r) < 1e-3 and np.linalg.norm(e) < 2e-4


def test_the_rotational_hlcmp_learns_stiffness_about_the_disturbed_axis_only(arm):
    """A steady 5 N m about the tool's x axis holds an error there (eps_r e_r > 0 at rest):
    the stiffness about x rises, about y and z it stays (Eq. 31 per tool axis)."""
    from hlcmp_drake.core.dmp import basis_centers_and_widths
    from hlcmp_drake.core.laws import ConstantImpedanceLaw, HlcmpGains
    from hlcmp_drake.core.rotation_law import PoseLaw, RotationalHlcmp

    centers, widths = basis_centers_and_widths(5, 4.0)
    q_kr = np.full(3, 20000.0)
    rotational = RotationalHlcmp(
        centers, widths, HlcmpGains(q_kr, np.full(3, 20.0), np.zeros(3), 5.0, np.full(3, 1.0))
    )
    translational = ConstantImpedanceLaw(
        np.full(3, 1000.0), np.full(3, 60.0), 5.0, np.full(3, 10.0)
    )
    law = PoseLaw(translational, rotational)
    theta0 = np.zeros((3, 3, 5))
    theta0[0], theta0[1] = 200.0, 2.0  # K_r = 200 N m/rad and D_r = 2 N m s/rad to start
    law_theta = theta0.ravel()
    _, _, theta = _closed_loop(arm, law, np.zeros(3), 0.5, law_theta, [5.0, 0.0, 0.0])
    gained = (theta.reshape(3, 3, 5) - theta0)[0]  # θ_kr's change, per tool axis
    # summed over the basis [N m/rad]; measured: x +25.4, z +0.25 (its error is 7 % of x's,
    # through the coupling of the 6-D inertia), y +1e-4
    assert gained[0].sum() > 10.0
    assert np.abs(gained[1:].sum(axis=1)).max() < 0.05 * gained[0].sum()
