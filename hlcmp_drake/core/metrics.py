"""Metrics computed from logged time series, pure numpy (paper Figs. 6-8, 12b, 13)."""

import numpy as np


def settle_time(
    t: np.ndarray, x: np.ndarray, target: float, tolerance: float, start: float, end: float
) -> float | None:
    """First time in [start, end) after which |x - target| < tolerance holds on every
    sample up to `end`; None if it does not hold on the last sample before `end`.

    t: (T,), x: (T,) one axis. Used for the 1-DOF reach and return times (Fig. 13).

    Parameters
    ----------
    t : (T,) array
        Sample times [s].
    x : (T,) array
        Position of one axis [m].
    target : float
        Target position [m].
    tolerance : float
        Band half-width [m].
    start, end : float
        The window [s], start included, end excluded.

    Returns
    -------
    float or None
        Settling time [s] (absolute, not from `start`), or None.
    """
    t, x = np.asarray(t), np.asarray(x)
    window = (t >= start) & (t < end)
    inside = np.abs(x[window] - target) < tolerance
    if inside.size == 0 or not inside[-1]:
        return None
    outside = np.flatnonzero(~inside)
    first = 0 if outside.size == 0 else outside[-1] + 1
    return float(t[window][first])


def value_at(t: np.ndarray, x: np.ndarray, time: float) -> float:
    """x(time) by linear interpolation of the logged samples (one axis).

    Parameters
    ----------
    t : (T,) array
        Sample times [s], increasing.
    x : (T,) array
        Samples of one axis (any unit).
    time : float
        Query time [s]; outside the log the end value is held.

    Returns
    -------
    float
        x(time), in the unit of `x`.
    """
    return float(np.interp(time, t, x))


def mean_abs_position_error(x: np.ndarray, xd: np.ndarray) -> np.ndarray:
    """Figs. 6/12: per-axis mean |x - x_d| over the run; (T, M) -> (M,).

    Parameters
    ----------
    x, xd : (T, M) arrays
        Measured and desired positions [m].

    Returns
    -------
    (M,) array
        Mean absolute position error [m].
    """
    return np.mean(np.abs(np.asarray(x) - xd), axis=0)


def mean_abs_force(f: np.ndarray) -> np.ndarray:
    """Fig. 7: per-axis mean |f| over the run; (T, M) -> (M,).

    Parameters
    ----------
    f : (T, M) array
        The logged force, one row per sample [N].

    Returns
    -------
    (M,) array
        The mean of |f| on each axis [N].
    """
    return np.mean(np.abs(f), axis=0)


def force_smoothness(f: np.ndarray) -> np.ndarray:
    """Figs. 8 / 12b: sum over the run of |second difference| of the force, per axis
    (the discrete form of the paper's sum of |f''|, in N: smaller is smoother).

    Parameters
    ----------
    f : (T, M) array
        Force at the log period [N]; T >= 3 for a second difference.

    Returns
    -------
    (M,) array
        Sum of |f[k+1] - 2 f[k] + f[k-1]| [N].
    """
    return np.sum(np.abs(np.diff(f, n=2, axis=0)), axis=0)


def max_abs_force(f: np.ndarray) -> np.ndarray:
    """Per-axis peak |f| over the run; (T, M) -> (M,).

    Parameters
    ----------
    f : (T, M) array
        Logged force [N].

    Returns
    -------
    (M,) array
        Per axis, the largest |f| of the run [N].
    """
    return np.max(np.abs(f), axis=0)


def probe_readings(
    distance: np.ndarray,
    resisting: np.ndarray,
    lateral: np.ndarray,
    in_push: np.ndarray,
    contact_threshold: float = 0.05,
) -> dict:
    """What `hlcmp probe` reports of a tool pushed through an object at constant speed.

    Parameters
    ----------
    distance : (T,) array
        The tool point's travel along the push from where the push starts [m].
    resisting : (T,) array
        The force on the tool against the push [N] (negative: the object pulls it on).
    lateral : (T,) array
        The magnitude of the force across the push (or along the lateral axis) [N].
    in_push : (T,) bool array
        The samples of the push itself (not the approach nor the way back).
    contact_threshold : float
        Resisting force [N] above which the push counts as in contact.

    Returns
    -------
    dict
        peak_force_N (largest resisting force in the push), depth_at_peak_m (travel from
        the first contact of the push to the peak), residual_force_N (mean resisting
        force over the last third of the push after the peak), max_lateral_force_N (over
        the whole path), min_resisting_force_N (the strongest pull-in, if negative).
    """
    push = np.flatnonzero(in_push)
    peak = push[int(np.argmax(resisting[push]))]
    touching = push[resisting[push] > contact_threshold]
    first_contact = touching[0] if touching.size else push[0]
    after_peak = push[push >= peak]
    last_third = after_peak[len(after_peak) - max(1, len(after_peak) // 3) :]
    readings = {
        "peak_force_N": resisting[peak],
        "depth_at_peak_m": distance[peak] - distance[first_contact],
        "residual_force_N": np.mean(resisting[last_third]),
        "max_lateral_force_N": np.max(np.abs(lateral)),
        "min_resisting_force_N": np.min(resisting[push]),
    }
    # + 0.0: no force is 0.0, not the -0.0 of a negated zero (it reached probe.json so).
    return {name: float(value) + 0.0 for name, value in readings.items()}


def wrist_readings(
    start_rotation: np.ndarray,
    angles: np.ndarray,
    rates: np.ndarray,
    stiffness: np.ndarray,
    damping: float,
    direction: np.ndarray,
    in_push: np.ndarray,
) -> dict:
    """What `hlcmp probe` reports of a tool on a compliant wrist: how far it turned towards
    the push's direction, and the torque the wrist held it with.

    The wrist's joints turn about the tool frame's x, y and z axes in that order, so the
    tool's orientation is R = R0 Rx(q_x) Ry(q_y) Rz(q_z) and its axis R e_z (Rz leaves
    it). The wrist's torque on joint k is -(K_k q_k + D v_k); quasi-statically the contact
    applies the opposite, K_k q_k + D v_k, about that joint's axis.

    Parameters
    ----------
    start_rotation : (3, 3) array
        R0, the tool frame in the world at wrist angles 0.
    angles, rates : (T, 3) arrays
        The wrist's joint angles [rad] and rates [rad/s].
    stiffness : (3,) array
        K per joint [N m/rad].
    damping : float
        D of every joint [N m s/rad].
    direction : (3,) array
        The push's direction, world (any length).
    in_push : (T,) bool array
        The samples of the push itself.

    Returns
    -------
    dict
        start_tilt_rad and final_tilt_rad (the angle between the tool's +z and the push's
        direction at the push's first and last sample), max_abs_wrist_torque_Nm (3: about
        the tool's x, y, z axes, over the whole path).
    """
    cx, sx = np.cos(angles[:, 0]), np.sin(angles[:, 0])
    cy, sy = np.cos(angles[:, 1]), np.sin(angles[:, 1])
    axis_in_start = np.stack([sy, -sx * cy, cx * cy], axis=1)  # Rx Ry e_z
    axis = axis_in_start @ np.asarray(start_rotation).T
    unit = np.asarray(direction, float) / np.linalg.norm(direction)
    tilt = np.arccos(np.clip(axis @ unit, -1.0, 1.0))
    push = np.flatnonzero(in_push)
    torque = angles * np.asarray(stiffness, float) + damping * rates
    return {
        "start_tilt_rad": float(tilt[push[0]]),
        "final_tilt_rad": float(tilt[push[-1]]),
        "max_abs_wrist_torque_Nm": [float(v) for v in np.max(np.abs(torque), axis=0)],
    }
