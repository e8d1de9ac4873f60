"""hlcmp_drake.core.rotation_law: the rotational errors in the tool frame, the exact sliding
surface, the rotational reference's rate, the bound at pi, and the 6-D laws: their
translational part equal to the bit to the 3-D Hl-CMP, the rotational part's signs."""

import numpy as np

from hlcmp_drake.core import quaternion as quat
from hlcmp_drake.core.dmp import basis_centers_and_widths, normalized_basis
from hlcmp_drake.core.laws import HlcmpGains, HlcmpLaw, TaskSpaceInstant
from hlcmp_drake.core.rotation_law import (
    PoseImpedance,
    PoseInstant,
    PoseLaw,
    RotationalHlcmp,
    constant_pose_impedance,
    rotation_errors,
    rotational_reference,
)


def _matrix(q):
    """R(q) from its columns, the images of the unit vectors (independent of
    `quaternion.to_matrix`, which the law uses)."""
    return np.column_stack([quat.rotate(q, axis) for axis in np.eye(3)])


def _random_quaternion(rng):
    axis = rng.normal(size=3)
    return quat.from_rotation_vector(axis / np.linalg.norm(axis) * rng.uniform(0, np.pi))


def test_the_error_is_the_rotation_from_the_desired_to_the_measured_tool_frame():
    rng = np.random.default_rng(0)
    for _ in range(20):
        q, q_d = _random_quaternion(rng), _random_quaternion(rng)
        e_r, _ = rotation_errors(q, np.zeros(3), q_d, np.zeros(3))
        np.testing.assert_allclose(
            _matrix(quat.from_rotation_vector(e_r)), _matrix(q_d).T @ _matrix(q), atol=1e-12
        )
        assert np.linalg.norm(e_r) <= np.pi


def test_a_turn_about_the_tools_own_axis_reads_on_that_axis_whatever_the_pose():
    rng = np.random.default_rng(1)
    for _ in range(10):
        q_d = _random_quaternion(rng)
        about_own_z = quat.multiply(q_d, quat.from_rotation_vector([0.0, 0.0, 0.2]))
        e_r, _ = rotation_errors(about_own_z, np.zeros(3), q_d, np.zeros(3))
        np.testing.assert_allclose(e_r, [0.0, 0.0, 0.2], atol=1e-12)


def _turned(q, omega_world, dt):
    """q after turning at the world angular velocity omega for dt."""
    return quat.multiply(quat.from_rotation_vector(np.asarray(omega_world) * dt), q)


def test_the_velocity_error_is_the_body_rate_of_the_error_rotation():
    """e_r' = J_r(e_r)^-1 omega_e, by central differences of e_r along a motion of both
    frames (the relation `rotational_reference` differentiates with)."""
    rng = np.random.default_rng(2)
    h = 1e-6
    for _ in range(10):
        q, q_d = _random_quaternion(rng), _random_quaternion(rng)
        omega, omega_d = rng.normal(size=3), rng.normal(size=3)
        e_r, omega_e = rotation_errors(q, omega, q_d, omega_d)
        plus, _ = rotation_errors(_turned(q, omega, h), omega, _turned(q_d, omega_d, h), omega_d)
        minus, _ = rotation_errors(_turned(q, omega, -h), omega, _turned(q_d, omega_d, -h), omega_d)
        rate = np.linalg.solve(quat.left_jacobian(-e_r), omega_e)
        np.testing.assert_allclose((plus - minus) / (2 * h), rate, atol=1e-7)


def test_on_the_sliding_surface_the_error_decays_along_its_axis_at_the_rate_pi():
    q_d = quat.from_rotation_vector([0.3, -0.2, 0.5])
    q = quat.multiply(q_d, quat.from_rotation_vector([1.2, 0.9, -0.4]))  # a 1.55 rad error
    pi, dt = 4.0, 1e-4
    e_start, _ = rotation_errors(q, np.zeros(3), q_d, np.zeros(3))
    for _ in range(2000):  # 0.2 s with omega_e = -pi e_r, omega_d = 0 (eps_r = 0)
        e_r, _ = rotation_errors(q, np.zeros(3), q_d, np.zeros(3))
        omega_world = quat.rotate(q, -pi * e_r)
        q = _turned(q, omega_world, dt)
    e_end, _ = rotation_errors(q, np.zeros(3), q_d, np.zeros(3))
    np.testing.assert_allclose(e_end, e_start * np.exp(-pi * 0.2), rtol=1e-3)


def test_the_reference_rate_is_the_derivative_of_the_reference():
    rng = np.random.default_rng(3)
    h, pi = 1e-6, 3.0
    for _ in range(10):
        q, q_d = _random_quaternion(rng), _random_quaternion(rng)
        omega, omega_d = rng.normal(size=3), rng.normal(size=3)

        def reference(t, q=q, q_d=q_d, omega=omega, omega_d=omega_d):
            qt, qdt = _turned(q, omega, t), _turned(q_d, omega_d, t)
            e_r, omega_e = rotation_errors(qt, omega, qdt, omega_d)
            return rotational_reference(
                quat.to_matrix(qt), omega, e_r, omega_e, omega_d, np.zeros(3), pi
            )

        rate = (reference(h)[0] - reference(-h)[0]) / (2 * h)
        np.testing.assert_allclose(reference(0.0)[1], rate, atol=1e-6)


def test_the_error_is_bounded_by_pi_and_turns_the_short_way_past_it():
    q_d = quat.from_rotation_vector([0.0, 0.0, 0.0])
    rest = np.zeros(3)
    before = rotation_errors(quat.from_rotation_vector([np.pi - 0.01, 0, 0]), rest, q_d, rest)[0]
    after = rotation_errors(quat.from_rotation_vector([np.pi + 0.01, 0, 0]), rest, q_d, rest)[0]
    np.testing.assert_allclose(before, [np.pi - 0.01, 0, 0], atol=1e-12)
    np.testing.assert_allclose(after, [-(np.pi - 0.01), 0, 0], atol=1e-12)


N_BASIS = 6


def _pose_instant(rng, coupled):
    inertia = np.zeros((6, 6))
    a, b = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    inertia[:3, :3], inertia[3:, 3:] = a @ a.T + np.eye(3), b @ b.T + 5 * np.eye(3)
    coriolis = np.zeros((6, 6))
    coriolis[:3, :3], coriolis[3:, 3:] = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    if coupled:
        inertia[:3, 3:] = 0.3 * rng.normal(size=(3, 3))
        inertia[3:, :3] = inertia[:3, 3:].T
        coriolis[:3, 3:], coriolis[3:, :3] = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    return PoseInstant(
        *(rng.normal(size=3) * 0.1 for _ in range(5)),
        orientation=_random_quaternion(rng),
        omega=rng.normal(size=3),
        desired_orientation=_random_quaternion(rng),
        omega_d=rng.normal(size=3),
        omega_d_dot=rng.normal(size=3),
        phase=0.37,
        inertia=inertia,
        coriolis=coriolis,
        gravity=rng.normal(size=6),
    )


def _laws():
    centers, widths = basis_centers_and_widths(N_BASIS, 4.0)
    translational = HlcmpGains(
        np.array([3000.0, 2000, 1000]),
        np.array([90.0, 80, 70]),
        np.array([9.0, 8, 7]),
        5.0,
        np.array([20.0, 30, 40]),
    )
    rotational = HlcmpGains(
        np.array([30.0, 20, 10]),
        np.array([0.9, 0.8, 0.7]),
        np.array([0.09, 0.08, 0.07]),
        3.0,
        np.array([0.5, 0.6, 0.7]),
    )
    law3 = HlcmpLaw(centers, widths, translational)
    return law3, PoseLaw(law3, RotationalHlcmp(centers, widths, rotational))


def test_the_translational_part_equals_the_3d_hlcmp_to_the_bit():
    rng = np.random.default_rng(4)
    law3, law6 = _laws()
    for coupled in (False, True):
        now = _pose_instant(rng, coupled)
        theta = rng.normal(size=law6.theta_size) * 50
        # the blocks copied contiguous, as the ticks pass them (a strided view would make
        # numba compile the 3-D law once more, for that layout)
        block = np.ascontiguousarray
        same = TaskSpaceInstant(
            now.x, now.xdot, now.xd, now.xd_dot, now.xd_ddot, now.phase,
            block(now.inertia[3:, 3:]), block(now.coriolis[3:, 3:]), now.gravity[3:],
        )  # fmt: skip
        three, six = law3.command(same, theta[: law3.theta_size]), law6.command(now, theta)
        for name in law3.log_fields:
            np.testing.assert_array_equal(six.logs[name], three.logs[name])
        np.testing.assert_array_equal(six.rates[: law3.theta_size], three.rates)
        if coupled:  # the 6-D inertia and Coriolis terms couple the halves
            assert np.all(np.abs(six.force[3:] - three.force) > 1e-6)
        else:
            np.testing.assert_array_equal(six.force[3:], three.force)


def test_a_tilt_is_pushed_back_and_learned_per_tool_axis():
    law3, law6 = _laws()
    rng = np.random.default_rng(5)
    now = _pose_instant(rng, coupled=False)
    q_d = _random_quaternion(rng)
    tilted = quat.multiply(q_d, quat.from_rotation_vector([0.05, 0.0, 0.0]))  # about tool x
    at_rest = dict(omega=np.zeros(3), omega_d=np.zeros(3), omega_d_dot=np.zeros(3))
    # no Coriolis: the reference velocity -pi_r R e_r would add C_x's torque
    changes = dict(orientation=tilted, desired_orientation=q_d, coriolis=np.zeros((6, 6)))
    tilted_now = PoseInstant(**{**now.__dict__, **at_rest, **changes})
    upright_now = PoseInstant(**{**tilted_now.__dict__, "orientation": q_d})
    theta = np.zeros(law6.theta_size)
    theta[law3.theta_size :].reshape(3, 3, N_BASIS)[0] = 40.0  # K_r = 40 N m/rad per axis
    tilted_out, upright_out = law6.command(tilted_now, theta), law6.command(upright_now, theta)
    np.testing.assert_allclose(tilted_out.logs["rotational_stiffness"], 40.0, rtol=1e-12)
    # the torque the tilt adds, in the tool frame: -(K_r + pi_r L_r) e_r, about tool x only
    extra = quat.rotate(quat.conjugate(tilted), tilted_out.force[:3] - upright_out.force[:3])
    rot = law6.rotational.gains
    assert extra[0] < -(40.0 + rot.pi * rot.gain_l[0]) * 0.05 * 0.99
    np.testing.assert_allclose(extra[1:], 0.0, atol=1e-9)
    # eps_r e_r > 0 on tool x: the x stiffness weights grow, y and z stay
    g = normalized_basis(now.phase, law3.centers, law3.widths)
    rates_kr = tilted_out.rates[law3.theta_size :].reshape(3, 3, N_BASIS)[0]
    np.testing.assert_allclose(rates_kr[0], rot.q_k[0] * rot.pi * 0.05**2 * g, rtol=1e-9)
    np.testing.assert_allclose(rates_kr[1:], 0.0, atol=1e-15)


def test_the_constant_impedance_is_the_hlcmp_with_fixed_profiles_and_no_feedforward():
    law3, law6 = _laws()
    rng = np.random.default_rng(6)
    now = _pose_instant(rng, coupled=True)
    impedance = PoseImpedance(
        np.array([500.0, 1000, 2000]), np.array([40.0, 50, 60]),
        np.array([10.0, 20, 30]), np.array([0.5, 1.0, 1.5]),
    )  # fmt: skip
    theta = np.zeros((6, 3, N_BASIS))
    theta[0], theta[1] = impedance.stiffness[:, None], impedance.damping[:, None]
    theta[3] = impedance.rotational_stiffness[:, None]
    theta[4] = impedance.rotational_damping[:, None]
    t, r = law3.gains, law6.rotational.gains
    constant = constant_pose_impedance(impedance, t.pi, t.gain_l, r.pi, r.gain_l)
    assert constant.theta_size == 0 and not constant.learns
    out = constant.command(now, None)
    assert out.rates is None
    np.testing.assert_allclose(out.force, law6.command(now, theta.ravel()).force, rtol=1e-12)


def test_the_halves_add_up_to_the_6d_operational_space_command():
    """F = Lambda V_e' + C_x V_e + p - [R (L_r eps_r + u_r + v_r); L eps + u + v], written
    out here with rotation matrices, against the law's split into two halves."""
    law3, law6 = _laws()
    rng = np.random.default_rng(7)
    now = _pose_instant(rng, coupled=True)
    theta = rng.normal(size=law6.theta_size) * 20
    t, r = law3.gains, law6.rotational.gains
    R, R_d = _matrix(now.orientation), _matrix(now.desired_orientation)
    e, edot = now.x - now.xd, now.xdot - now.xd_dot
    e_r = quat.to_rotation_vector(quat.multiply(quat.conjugate(now.desired_orientation),
                                                now.orientation))  # fmt: skip
    omega_e = R.T @ (now.omega - now.omega_d)
    error_rate = np.linalg.solve(quat.left_jacobian(-e_r), omega_e)
    omega_ref = now.omega_d - r.pi * R @ e_r
    omega_ref_dot = now.omega_d_dot - r.pi * (np.cross(now.omega, R @ e_r) + R @ error_rate)
    v_e = np.concatenate([omega_ref, now.xd_dot - t.pi * e])
    a_e = np.concatenate([omega_ref_dot, now.xd_ddot - t.pi * edot])
    g = normalized_basis(now.phase, law3.centers, law3.widths)
    k, d, v, kr, dr, vr = (part @ g for part in theta.reshape(6, 3, N_BASIS))
    eps, eps_r = edot + t.pi * e, omega_e + r.pi * e_r
    expected = (
        now.inertia @ a_e
        + now.coriolis @ v_e
        + now.gravity
        - np.concatenate(
            [
                R @ (r.gain_l * eps_r + kr * e_r + dr * omega_e + vr),
                t.gain_l * eps + k * e + d * edot + v,
            ]
        )
    )
    np.testing.assert_allclose(law6.command(now, theta).force, expected, rtol=1e-12, atol=1e-12)
    assert np.allclose(R_d @ _matrix(quat.from_rotation_vector(e_r)), R)
