"""What makes a real arm differ from its model (the scenario's `robot_imperfection`): its
joints' friction and the velocity estimate its driver reports. Not the paper's equations:
the world a controller meets on a real iiwa. Pure numpy."""

import math

import numpy as np


def joint_friction_torque(
    velocity: np.ndarray, viscous: np.ndarray, coulomb: np.ndarray, speed: float
) -> np.ndarray:
    """The joints' friction torque, viscous and smoothed Coulomb:

    .. math:: \\tau_f = -(F_v \\dot q + F_c \\tanh(\\dot q / v_s))

    the model of Stürz et al. 2017 (Eq. 1, F_v q' + F_s sign(q')) with the sign smoothed,
    so that the torque is continuous at rest.

    Parameters
    ----------
    velocity : (n,) array
        The joint velocities q' [rad/s].
    viscous : (n,) array
        F_v per joint [N m s/rad], >= 0.
    coulomb : (n,) array
        F_c per joint [N m], >= 0.
    speed : float
        v_s [rad/s], > 0: the speed at which the Coulomb part reaches tanh(1) of F_c.

    Returns
    -------
    (n,) array
        The torque friction applies to each joint [N m] (opposing its velocity).
    """
    return -(viscous * velocity + coulomb * np.tanh(velocity / speed))


def low_pass_retention(cutoff_hz: float, period: float) -> float:
    """The coefficient a of a first-order low-pass sampled every `period`,
    y_k = a y_(k-1) + (1 - a) u_k, with

    .. math:: a = 1 - T / (T + RC), \\quad RC = 1 / (2 \\pi f_c)

    (drake-iiwa-driver's velocity filter, kuka-driver/low_pass_filter.h, which it runs on
    the joint position differences over the FRI period).

    Parameters
    ----------
    cutoff_hz : float
        f_c [Hz], > 0.
    period : float
        T, the sample period [s], > 0.

    Returns
    -------
    float
        a, in (0, 1): the share of the last output kept.
    """
    rc = 1.0 / (2.0 * math.pi * cutoff_hz)
    return 1.0 - period / (period + rc)


def force_noise_samples(
    sigma: np.ndarray, seed: int, period: float, duration: float
) -> tuple[np.ndarray, np.ndarray]:
    """A force sensor's Gaussian noise, one independent draw per axis every `period`, from
    a generator seeded with `seed` (the same seed, the same noise).

    Parameters
    ----------
    sigma : (3,) array
        The standard deviation per axis [N], >= 0.
    seed : int
        The generator's seed, >= 0.
    period : float
        The time between draws [s], > 0.
    duration : float
        The last time a draw must cover [s], >= 0.

    Returns
    -------
    times : (K,) array
        k * period, k = 0 ... K - 1, K = ceil(duration / period) + 2 (one past the end).
    noise : (K, 3) array
        The draw that holds from each time on [N].
    """
    count = int(math.ceil(duration / period - 1e-9)) + 2
    noise = np.random.default_rng(seed).standard_normal((count, 3)) * np.asarray(sigma, float)
    return period * np.arange(count), noise
