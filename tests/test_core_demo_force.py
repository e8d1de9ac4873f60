"""hlcmp_drake.core.demo_force: a demonstrated force encoded on the phase basis as
feed-forward weights follows the force, with its sign, on demonstrations no one tuned for."""

import numpy as np
import pytest

from hlcmp_drake.core.demo_force import feedforward_along, fit_feedforward_weights
from hlcmp_drake.core.dmp import DmpSettings, phase_at


def untuned_demonstration(seed):
    """A random contact force as a wrist sensor would record it: a random duration,
    unevenly sampled at about 100 Hz, a plateau of contact with random onset, release and
    level per axis, a slow random wobble on top, and 1 % sensor noise."""
    rng = np.random.default_rng(seed)
    duration = rng.uniform(3.0, 10.0)
    t = np.cumsum(rng.uniform(0.005, 0.015, int(duration / 0.01)))
    force = np.zeros((len(t), 3))
    for m in range(3):
        onset, release = np.sort(rng.uniform(0.1, 0.9, 2)) * t[-1]
        ramp = rng.uniform(0.2, 0.6)
        contact = np.clip((t - onset) / ramp, 0, 1) * np.clip((release - t) / ramp, 0, 1)
        wobble = sum(
            rng.uniform(0.5, 2.0)
            * np.sin(2 * np.pi * rng.uniform(0.1, 0.8) * t + rng.uniform(0, 6))
            for _ in range(3)
        )
        force[:, m] = rng.uniform(-15, 15) * contact + wobble
    force += 0.01 * np.ptp(force, axis=0) * rng.standard_normal(force.shape)
    return t - t[0], force


@pytest.mark.parametrize("seed", range(5))
def test_the_encoded_force_follows_an_untuned_demonstration(seed):
    t, force = untuned_demonstration(seed)
    settings = DmpSettings()
    theta_v = fit_feedforward_weights(t, force, settings)
    assert theta_v.shape == (3, settings.n_basis)
    encoded = feedforward_along(theta_v, phase_at(t, t[-1], settings.alpha_s), settings)
    rms = np.sqrt(np.mean((encoded - force) ** 2, axis=0))
    assert np.all(rms <= 0.1 * np.ptp(force, axis=0)), (rms, np.ptp(force, axis=0))


def test_a_constant_force_is_encoded_exactly_with_its_sign():
    # g(s) sums to 1 (Eq. 16), so a constant force is one weight value: v = +f, never -f.
    t = np.linspace(0.0, 4.0, 401)
    force = np.tile([2.0, -3.0, 7.5], (len(t), 1))
    settings = DmpSettings(n_basis=12)
    theta_v = fit_feedforward_weights(t, force, settings)
    np.testing.assert_allclose(theta_v, np.repeat(force[:1].T, 12, axis=1), atol=1e-6)
    s = phase_at(np.linspace(0.0, 6.0, 50), 4.0, settings.alpha_s)  # also after tau
    np.testing.assert_allclose(feedforward_along(theta_v, s, settings), force[:50], atol=1e-6)


def test_after_the_demonstration_the_profile_holds_the_force_it_ends_with():
    t = np.linspace(0.0, 5.0, 501)
    force = np.column_stack([np.where(t < 2.5, 0.0, 4.0), np.sin(t), 3.0 * t / 5.0])
    settings = DmpSettings()
    theta_v = fit_feedforward_weights(t, force, settings)
    late = feedforward_along(theta_v, phase_at(np.array([6.0, 7.5]), 5.0, 4.0), settings)
    np.testing.assert_allclose(late, np.tile(force[-1], (2, 1)), atol=0.1)


def test_the_phase_maps_the_force_to_another_duration():
    # The weights live on the phase: replayed at twice tau, the force comes twice as late.
    t = np.linspace(0.0, 4.0, 401)
    force = np.column_stack([np.exp(-(((t - 1.0) / 0.4) ** 2)) * 10.0])
    settings = DmpSettings()
    theta_v = fit_feedforward_weights(t, force, settings)
    slow = feedforward_along(theta_v, phase_at(2 * t, 8.0, settings.alpha_s), settings)
    fast = feedforward_along(theta_v, phase_at(t, 4.0, settings.alpha_s), settings)
    np.testing.assert_allclose(slow, fast, atol=1e-12)
    assert abs(t[np.argmax(fast)] - 1.0) < 0.05
