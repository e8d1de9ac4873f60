"""Metrics computed from logged time series, pure numpy (paper Figs. 6-8, 12b, 13)."""

import numpy as np


def settle_time(t: np.ndarray, x: np.ndarray, target: float, tolerance: float, start: float,
                end: float) -> float | None:
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
