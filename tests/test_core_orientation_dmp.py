"""hlcmp_drake.core.orientation_dmp: the orientation DMP on demonstrations no one tuned for
(seeded: noisy, unevenly sampled, turns of 190-330 deg about tilted axes, quaternions that
switch hemisphere), temporal scaling, new goals, a goal switched mid-rollout, and the
world-frame angular velocity."""

import numpy as np
import pytest
from conftest import minimum_jerk, tilted_turn

from hlcmp_drake.core import orientation_dmp as orientation_module
from hlcmp_drake.core import quaternion as quat
from hlcmp_drake.core.orientation_dmp import OrientationDmp

STEP_S = 0.002


def _degrees(a, b):
    return np.degrees(quat.geodesic_angle(a, b))


def _path_length_deg(q):
    return float(np.sum(_degrees(q[1:], q[:-1])))


@pytest.mark.parametrize("seed", range(6))
def test_acceptance_on_seeded_demonstrations(seed):
    t, _, q, truth = tilted_turn(seed)
    assert np.any(np.sum(q[1:] * q[:-1], axis=1) < 0)  # the samples do switch hemisphere
    dmp = OrientationDmp.fit(t, q)
    t_r, q_r, _, _ = dmp.rollout(dt=STEP_S)
    error = _degrees(q_r, truth(t_r))
    assert np.sqrt(np.mean(error**2)) <= 1.0
    assert error[-1] <= 0.5
    assert _degrees(q_r[1:], q_r[:-1]).max() <= 2.0
    # The turn beyond 180 deg keeps its direction: as long a path as the demonstrated one.
    fine = np.linspace(0.0, t[-1], 3001)
    assert _path_length_deg(q_r) == pytest.approx(_path_length_deg(truth(fine)), rel=0.02)
    assert np.degrees(np.linalg.norm(dmp.demonstrated_rotation)) > 180.0
    # Twice the duration: the same orientations at the same phase, and no larger steps.
    _, q_slow, _, _ = dmp.rollout(dt=STEP_S, tau=2 * dmp.tau)
    assert _degrees(q_slow[::2], q_r).max() <= 0.01
    assert _degrees(q_slow[1:], q_slow[:-1]).max() <= 2.0
    # After tau it stays at its goal.
    _, q_long, _, _ = dmp.rollout(duration=3 * dmp.tau, dt=STEP_S)
    assert _degrees(q_long[len(t_r) - 1 :], dmp.goal).max() <= 0.5


def test_the_angular_velocity_is_the_world_frame_rate_of_the_orientation():
    t, _, q, _ = tilted_turn(0)
    _, q_r, omega, _ = OrientationDmp.fit(t, q).rollout(dt=0.001)
    world = quat.to_rotation_vector(quat.multiply(q_r[1:], quat.conjugate(q_r[:-1]))) / 0.001
    midpoint = 0.5 * (omega[1:] + omega[:-1])
    assert np.abs(world - midpoint).max() < 1e-3 * np.abs(omega).max()
    body = quat.rotate(quat.conjugate(q_r[:-1]), world)
    assert np.abs(body - midpoint).max() > 0.1 * np.abs(omega).max()


def test_a_new_goal_is_reached_from_the_same_start_turning_the_same_way():
    t, _, q, _ = tilted_turn(1)
    dmp = OrientationDmp.fit(t, q)
    new_goal = quat.multiply(quat.from_rotation_vector(np.radians([12.0, -8.0, 10.0])), dmp.goal)
    t_r, q_r, omega, _ = dmp.with_goal(new_goal).rollout(duration=2 * dmp.tau, dt=STEP_S)
    assert _degrees(q_r[0], dmp.start) < 1e-9
    assert _degrees(q_r[-1], new_goal) <= 0.5
    assert np.linalg.norm(omega[-1]) < 1e-2
    _, q_demo, _, _ = dmp.rollout(dt=STEP_S)
    assert _path_length_deg(q_r) > 180.0
    assert _path_length_deg(q_r) == pytest.approx(_path_length_deg(q_demo), rel=0.15)


def test_a_new_goal_half_a_turn_away_turns_as_the_demonstration_did():
    t = np.linspace(0.0, 2.0, 201)
    angles = np.radians(90.0) * minimum_jerk(t / 2.0)
    q = quat.from_rotation_vector(angles[:, None] * np.array([0.0, 0.0, 1.0]))
    dmp = OrientationDmp.fit(t, q)
    half_turn = np.array([0.0, 0.0, 0.0, 1.0])  # pi about z: +z and -z are the same goal
    _, q_r, omega, _ = dmp.with_goal(half_turn).rollout(duration=2 * dmp.tau, dt=STEP_S)
    assert _degrees(q_r[-1], half_turn) < 0.5
    assert omega[:, 2].min() > -0.01  # about +z, as the demonstration turned
    assert _path_length_deg(q_r) == pytest.approx(180.0, abs=1.0)


def test_a_goal_switched_mid_rollout_keeps_the_angular_velocity_continuous():
    t, _, q, _ = tilted_turn(2)
    dmp = OrientationDmp.fit(t, q)
    dt, first, second = 0.001, 0.5 * dmp.tau, 0.55 * dmp.tau
    goal_a = quat.multiply(quat.from_rotation_vector(np.radians([0.0, 30.0, 0.0])), dmp.goal)
    goal_b = quat.multiply(quat.from_rotation_vector(np.radians([-20.0, 0.0, 10.0])), dmp.goal)
    t_r, q_r, omega, _ = dmp.rollout(
        duration=2 * dmp.tau, dt=dt, goal_changes=[(first, goal_a), (second, goal_b)]
    )
    jumps = np.linalg.norm(np.diff(omega, axis=0), axis=1)
    for when in (first, second):
        k = int(round(when / dt))
        # At most 20 rad/s^2 over a step: no jump (a jump to the goal filter's speed, 30 deg
        # over its settling, would be about 1 rad/s).
        assert jumps[k - 2 : k + 2].max() < 0.02, (when, jumps[k - 2 : k + 2])
    assert _degrees(q_r[-1], goal_b) <= 0.5
    assert _degrees(q_r[1:], q_r[:-1]).max() <= 1.0
    # Before the first switch it is the plain rollout.
    _, q_plain, _, _ = dmp.rollout(duration=2 * dmp.tau, dt=dt)
    assert _degrees(q_r[: int(first / dt)], q_plain[: int(first / dt)]).max() < 1e-9


def test_a_demonstration_that_comes_back_keeps_its_shape():
    t = np.linspace(0.0, 2.0, 301)
    swing = np.radians(120.0) * np.sin(np.pi * t / 2.0) ** 2
    axis = np.array([0.6, 0.0, 0.8])
    start = quat.from_rotation_vector([0.1, -0.2, 0.3])
    q = quat.multiply(quat.from_rotation_vector(swing[:, None] * axis), start)
    dmp = OrientationDmp.fit(t, q)
    assert not dmp.goal_scaled
    t_r, q_r, _, _ = dmp.rollout(dt=STEP_S)
    truth = quat.multiply(
        quat.from_rotation_vector(
            (np.radians(120.0) * np.sin(np.pi * t_r / 2.0) ** 2)[:, None] * axis
        ),
        start,
    )
    assert np.sqrt(np.mean(_degrees(q_r, truth) ** 2)) < 0.2


def test_the_goal_is_the_settled_ends_mean_whatever_the_samples_signs():
    from hlcmp_drake.core.orientation_dmp import settled_goal

    rng = np.random.default_rng(3)
    true_goal = quat.from_rotation_vector(np.array([0.3, -1.2, 2.0]))
    t = np.linspace(0.0, 1.0, 201)  # 5 ms apart: 11 samples in the last 50 ms
    noisy = quat.multiply(quat.from_rotation_vector(rng.normal(0.0, 0.01, (201, 3))), true_goal)
    noisy *= rng.choice([-1.0, 1.0], 201)[:, None]
    last_only = settled_goal(t, noisy, 0.0)
    np.testing.assert_allclose(last_only, noisy[-1])
    mean = settled_goal(t, noisy, 0.05)
    assert np.isclose(np.linalg.norm(mean), 1.0) and mean @ noisy[-1] > 0
    assert _degrees(mean, true_goal) < 0.6 * _degrees(last_only, true_goal)


@pytest.mark.parametrize("samples_per_chunk", [2, 7, 1000])
def test_the_fit_in_chunks_is_the_fit_of_all_samples_at_once(monkeypatch, samples_per_chunk):
    """The responses stepped chunk by chunk, each from where the one before ended (an hour
    at 1 kHz does not fit in memory at once), give the weights of one pass."""
    t, _, q, _ = tilted_turn(3)
    whole = OrientationDmp.fit(t, q).theta
    n = OrientationDmp.fit(t, q).settings.n_basis
    monkeypatch.setattr(orientation_module, "FEATURE_CHUNK_VALUES", n * samples_per_chunk)
    chunked = OrientationDmp.fit(t, q).theta
    np.testing.assert_allclose(chunked, whole, rtol=1e-9, atol=1e-9 * np.abs(whole).max())
