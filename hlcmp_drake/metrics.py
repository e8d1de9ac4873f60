"""Metrics computed from logged time series, pure numpy (paper Figs. 6-8, 12b, 13)."""

import numpy as np


def settle_time(t, x, target, tolerance, start, end):
    """First time in [start, end) after which |x - target| < tolerance holds on every
    sample up to `end`; None if it does not hold on the last sample before `end`.

    t: (T,), x: (T,) one axis. Used for the 1-DOF reach and return times (Fig. 13).
    """
    t, x = np.asarray(t), np.asarray(x)
    window = (t >= start) & (t < end)
    inside = np.abs(x[window] - target) < tolerance
    if inside.size == 0 or not inside[-1]:
        return None
    outside = np.flatnonzero(~inside)
    first = 0 if outside.size == 0 else outside[-1] + 1
    return float(t[window][first])


def value_at(t, x, time):
    """x(time) by linear interpolation of the logged samples (one axis)."""
    return float(np.interp(time, t, x))


def mean_abs_position_error(x, xd):
    """Figs. 6/12: per-axis mean |x - x_d| over the run; (T, M) -> (M,)."""
    return np.mean(np.abs(np.asarray(x) - xd), axis=0)


def mean_abs_force(f):
    """Fig. 7: per-axis mean |f| over the run; (T, M) -> (M,)."""
    return np.mean(np.abs(f), axis=0)


def force_smoothness(f):
    """Figs. 8 / 12b: sum over the run of |second difference| of the force, per axis
    (the discrete form of the paper's sum of |f''|, in N: smaller is smoother)."""
    return np.sum(np.abs(np.diff(f, n=2, axis=0)), axis=0)


def max_abs_force(f):
    """Per-axis peak |f| over the run; (T, M) -> (M,)."""
    return np.max(np.abs(f), axis=0)
