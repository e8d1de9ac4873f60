"""hlcmp_drake.core.dmp: the DMP's basis, fit and rollout (goal, temporal scaling, the
substitute amplitude of a flat axis, noisy and tremor demonstrations)."""

import numpy as np
import pytest

from hlcmp_drake.core import dmp as dmp_module
from hlcmp_drake.core.demo_force import fit_feedforward_weights
from hlcmp_drake.core.dmp import (
    Dmp,
    DmpSettings,
    basis_centers_and_widths,
    forcing_basis,
    forcing_target,
    normalized_basis,
    phase_at,
    rbf_activations,
    resample_and_differentiate,
    transformation_rates,
)


def _interp(t_new, t, positions):
    return np.column_stack(
        [np.interp(t_new, t, positions[:, m]) for m in range(positions.shape[1])]
    )


def test_normalized_basis_is_a_partition_of_unity():
    centers, widths = basis_centers_and_widths(20, 4.0)
    s = phase_at(np.linspace(0, 1.2, 50), 1.0, 4.0)
    g = normalized_basis(s, centers, widths)
    assert g.shape == (50, 20)
    np.testing.assert_allclose(g.sum(axis=1), 1.0)
    # Eq. 10 directly
    np.testing.assert_allclose(
        rbf_activations(0.5, centers, widths), np.exp(-0.5 * widths * (0.5 - centers) ** 2)
    )


def test_forcing_basis_scales_with_phase_and_amplitude():
    centers, widths = basis_centers_and_widths(5, 4.0)
    gp = forcing_basis(0.4, centers, widths, np.array([2.0, -1.0]))
    g = normalized_basis(0.4, centers, widths)
    np.testing.assert_allclose(gp, np.vstack([g * 0.4 * 2.0, g * 0.4 * -1.0]))


def test_forcing_target_inverts_the_transformation_system():
    # With f = f_target(p, p', p''), Eq. 15 must give back p'' (Eq. 19 is Eq. 15 solved for f).
    p, pdot, pddot, goal, tau, alpha, beta = 0.2, -0.3, 1.7, 0.5, 2.0, 25.0, 6.25
    f = forcing_target(p, pdot, pddot, goal, tau, alpha, beta)
    _, zdot = transformation_rates(p, tau * pdot, f, goal, tau, alpha, beta)
    assert zdot / tau == pytest.approx(pddot)


def test_reproduces_a_smooth_demonstration_within_one_percent_of_its_range(smooth_demo):
    t, positions = smooth_demo
    dmp = Dmp.fit(t, positions, "xyz")
    t_r, p, *_ = dmp.rollout(dt=0.002)
    error = np.abs(p - _interp(t_r, t, positions)).max(axis=0) / np.ptp(positions, axis=0)
    assert np.all(error < 0.01), error


def test_converges_to_a_new_goal_and_keeps_start(smooth_demo):
    t, positions = smooth_demo
    dmp = Dmp.fit(t, positions, "xyz")
    new_goal = dmp.goal + np.array([0.1, -0.05, 0.08])
    t_r, p, v, *_ = dmp.with_goal(new_goal).rollout(duration=3 * dmp.tau, dt=0.002)
    np.testing.assert_allclose(p[0], dmp.start)
    np.testing.assert_allclose(p[-1], new_goal, atol=1e-3)
    assert np.abs(v[-1]).max() < 1e-2


def test_temporal_scaling_keeps_the_shape(smooth_demo):
    t, positions = smooth_demo
    dmp = Dmp.fit(t, positions, "xyz")
    _, p1, v1, *_ = dmp.rollout(dt=0.002)
    _, p2, v2, *_ = dmp.rollout(dt=0.004, tau=2 * dmp.tau)  # twice as slow, same number of steps
    assert p2.shape == p1.shape
    np.testing.assert_allclose(p2, p1, atol=1e-6)
    np.testing.assert_allclose(v2, v1 / 2, atol=1e-6)


def test_goal_equal_to_start_axis_is_reproduced():
    # Reach down, hold, come back up: z ends where it started (SPEC section 2).
    t = np.linspace(0, 3, 601)
    z = 0.4 - 0.1 * np.sin(np.pi * t / 3) ** 2
    x = 0.5 + 0.2 * (10 * (t / 3) ** 3 - 15 * (t / 3) ** 4 + 6 * (t / 3) ** 5)
    positions = np.column_stack([x, z])
    dmp = Dmp.fit(t, positions, ("x", "z"))
    assert list(dmp.goal_scaled) == [True, False]
    t_r, p, *_ = dmp.rollout(dt=0.002)
    error = np.abs(p - _interp(t_r, t, positions)).max(axis=0) / np.ptp(positions, axis=0)
    assert np.all(error < 0.01), error
    assert p[:, 1].min() == pytest.approx(0.3, abs=0.002)  # it does go down
    assert p[-1, 1] == pytest.approx(0.4, abs=0.002)  # and comes back up


def test_without_the_substitute_amplitude_the_flat_axis_is_lost():
    # The reason for the substitute: with amplitude g - p0 ~ 0 the forcing term vanishes.
    t = np.linspace(0, 3, 601)
    z = 0.4 - 0.1 * np.sin(np.pi * t / 3) ** 2
    dmp = Dmp.fit(t, z[:, None], ("z",))
    broken = Dmp(
        dmp.settings,
        dmp.tau,
        dmp.start,
        dmp.goal,
        dmp.theta_p,
        np.array([dmp.goal[0] - dmp.start[0]]),
        np.array([True]),
        ("z",),
    )
    _, p, *_ = broken.rollout(dt=0.002)
    assert p[:, 0].min() > 0.39


def test_noisy_unevenly_sampled_demonstration(smooth_demo):
    t, positions = smooth_demo
    rng = np.random.default_rng(7)
    t_uneven = np.sort(np.concatenate([[0.0, 2.0], rng.uniform(0, 2, 600)]))
    t_uneven = np.unique(t_uneven)
    noisy = _interp(t_uneven, t, positions) + rng.normal(0, 2e-4, (len(t_uneven), 3))
    dmp = Dmp.fit(t_uneven, noisy, "xyz")
    t_r, p, *_ = dmp.rollout(dt=0.002)
    error = np.abs(p - _interp(t_r, t, positions)).max(axis=0) / np.ptp(positions, axis=0)
    assert np.all(error < 0.02), error


def test_resampling_gives_a_uniform_grid_and_smooth_derivatives():
    t = np.array([0, 0.1, 0.15, 0.4, 0.5, 0.8, 1.0])
    t_u, p, pdot, pddot = resample_and_differentiate(t, 2 * t, smoothing_s=0.0)
    assert np.allclose(np.diff(t_u), t_u[1] - t_u[0])
    np.testing.assert_allclose(pdot, 2.0, atol=1e-9)
    np.testing.assert_allclose(pddot, 0.0, atol=1e-6)


def test_settings_validation():
    with pytest.raises(ValueError):
        DmpSettings(n_basis=1)
    with pytest.raises(ValueError, match="n_basis must be between 2 and 1000, got 100000"):
        DmpSettings(n_basis=100_000)  # its fit's N x N system would take 80 GB
    assert DmpSettings(alpha=40).beta_value == 10
    settings = DmpSettings()
    settings.alpha = 40  # as the YAML loader sets it: beta follows alpha
    assert settings.beta_value == 10


@pytest.mark.parametrize("n_basis", [10, 30, 130, 400])
def test_the_normalized_basis_is_defined_at_every_phase(n_basis):
    """Past the last centre the activations of many narrow basis functions all underflow
    (at N = 130 every one is 0 at s = 0): Eq. 16 still sums to 1 there, and where the
    plain ratio is defined it gives the same numbers."""
    centers, widths = basis_centers_and_widths(n_basis, 4.0)
    s = np.concatenate([np.linspace(0.0, 1.0, 2001), [centers[-1]]])
    g = normalized_basis(s, centers, widths)
    np.testing.assert_allclose(g.sum(axis=1), 1.0, rtol=1e-12)
    omega = rbf_activations(s, centers, widths)
    total = omega.sum(axis=1)
    defined = total > 1e-250  # well inside the normal doubles
    plain = omega[defined] / total[defined, None]
    np.testing.assert_allclose(g[defined], plain, rtol=1e-9, atol=1e-12)
    inside = s >= centers[-1]  # the bundled runs' phases until tau: the very same bits
    assert np.array_equal(g[inside], omega[inside] / total[inside, None])
    if n_basis >= 130:
        assert not defined.all()  # the case this guards
    assert np.argmax(g[0]) == n_basis - 1  # at s = 0 the last centre's, as it tends to


def test_a_tremor_demonstration_stays_at_its_goal_after_tau(smooth_demo):
    """Noise near the end must not leave large weights on the last kernels: the fit sees
    the demonstration held at rest after tau (TAIL_FRACTION), so the DMP settles at g."""
    t, positions = smooth_demo
    rng = np.random.default_rng(11)
    tremor = 2e-4 * np.sin(2 * np.pi * rng.uniform(8, 12, 3) * t[:, None] + rng.uniform(0, 6, 3))
    dmp = Dmp.fit(t, positions + tremor, "xyz", DmpSettings(smoothing_s=0.03))
    t_r, p, *_ = dmp.rollout(duration=2 * dmp.tau, dt=0.002)
    after = t_r >= dmp.tau
    assert np.abs(p[after] - dmp.goal).max() < 1e-3


@pytest.mark.parametrize("chunk_values", [90, 90 * 7, 90 * 1000])
def test_the_fit_in_chunks_is_the_fit_of_all_samples_at_once(monkeypatch, chunk_values):
    """The normal equations summed chunk by chunk (an hour at 1 kHz does not fit in memory
    at once) give the weights one regression over every sample gives."""
    t = np.linspace(0.0, 2.0, 1501)
    positions = np.column_stack([np.sin(t), 0.2 * t**2, np.cos(3 * t)])
    settings = DmpSettings(n_basis=30)
    whole = Dmp.fit(t, positions, ("x", "y", "z"), settings).theta_p
    rng = np.random.default_rng(3)
    force = rng.normal(size=positions.shape)
    whole_v = fit_feedforward_weights(t, force, settings)
    monkeypatch.setattr(dmp_module, "FEATURE_CHUNK_VALUES", chunk_values)  # 1, 7, 1000 samples
    chunked = Dmp.fit(t, positions, ("x", "y", "z"), settings).theta_p
    np.testing.assert_allclose(chunked, whole, rtol=1e-9, atol=1e-9 * np.abs(whole).max())
    chunked_v = fit_feedforward_weights(t, force, settings)
    np.testing.assert_allclose(chunked_v, whole_v, rtol=1e-9, atol=1e-9 * np.abs(whole_v).max())


def test_a_rollouts_forcing_in_chunks_is_the_forcing_at_once(monkeypatch):
    t = np.linspace(0.0, 2.0, 501)
    dmp = Dmp.fit(t, np.column_stack([np.sin(t), t**2]), ("x", "z"), DmpSettings(n_basis=20))
    whole = dmp.rollout(duration=2.5)
    monkeypatch.setattr(dmp_module, "FEATURE_CHUNK_VALUES", 40 * 7)  # 7 samples a chunk
    for got, expected in zip(dmp.rollout(duration=2.5), whole):
        np.testing.assert_array_equal(got, expected)
    assert dmp.forcing(0.5).shape == (2,)


def test_every_fit_holds_the_demonstration_at_rest_over_the_one_settled_tail(monkeypatch):
    """The position, orientation and force fits take the samples after tau from
    `with_settled_tail` (the orientation's and the force's computed their own copy of it):
    a longer TAIL_FRACTION there changes the weights of each."""
    from hlcmp_drake.core.orientation_dmp import OrientationDmp
    from hlcmp_drake.core.quaternion import from_rotation_vector

    t = np.linspace(0.0, 2.0, 401)
    positions = np.column_stack([np.sin(t), 0.2 * t**2])
    quaternions = from_rotation_vector(np.outer(np.sin(t), [0.1, 0.3, 1.0]))
    force = np.column_stack([np.cos(2 * t), t])
    settings = DmpSettings(n_basis=20)

    def weights():
        return {
            "position": Dmp.fit(t, positions, ("x", "z"), settings).theta_p,
            "orientation": OrientationDmp.fit(t, quaternions, settings).theta,
            "force": fit_feedforward_weights(t, force, settings),
        }

    usual = weights()
    monkeypatch.setattr(dmp_module, "TAIL_FRACTION", 2 * dmp_module.TAIL_FRACTION)
    longer = weights()
    assert [fit for fit in usual if np.array_equal(usual[fit], longer[fit])] == []


def test_the_fit_sample_count_is_the_resampled_demonstration_and_its_settled_end():
    """What `hlcmp fit` weighs its basis count against: 201 samples over 2 s and half as
    many more at rest; a recording at 50 Hz is resampled every 10 ms first."""
    from hlcmp_drake.core.dmp import fit_sample_count

    assert fit_sample_count(np.linspace(0.0, 2.0, 201)) == 301
    assert fit_sample_count(np.linspace(0.0, 8.0, 401)) == 801 + 400
