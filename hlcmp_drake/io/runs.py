"""One controller's run as logged series, and the timeseries.npz contract.

This is the data that passes from simulation (run/) to evaluation (experiments/) and
presentation (present/); it holds arrays only, nothing of Drake."""

from __future__ import annotations

import dataclasses as dc
from collections.abc import Iterable

import numpy as np


@dc.dataclass
class RunResult:
    """One controller's run: logged series on a common time base, and how it ended.

    Attributes
    ----------
    controller : str
        The controller's label in the scenario (or a trial's name, e.g. "trial_2").
    t : (T,) array
        Log sample times [s].
    series : dict of str to (T, k) arrays
        The logged series: "x", "xd", "f_ext", "fc", "plant_state", "saturated_joints",
        in an arm world "tau_ext" (the wrist torque about the tool point, tool frame),
        and for a learning controller "Ks", "Kd", "v", "u", "eps" (a 6-D controller's
        rotational ones besides).
    status : str
        "ok", or "unstable" when the run was stopped (see `reason`, `stop_time`).
    reason : str
        Why an unstable run stopped.
    stop_time : float or None
        Simulated time [s] at which it stopped.
    theta : tuple of three (M, N) arrays or None
        A learning controller's (theta_k, theta_d, theta_v) when the run ended.
    """

    controller: str
    t: np.ndarray
    series: dict
    status: str = "ok"
    reason: str = ""
    stop_time: float | None = None
    theta: tuple | None = None


def timeseries_arrays(runs: dict[str, RunResult]) -> dict[str, np.ndarray]:
    """The timeseries.npz contract: `t`, and `CTRL/NAME` arrays (T x k), NaN-padded where
    a run stopped early.

    Parameters
    ----------
    runs : dict of str to RunResult
        The runs by controller label.

    Returns
    -------
    dict of str to array
        "t" (the longest run's times) and one padded array per run and series.
    """
    longest = max(runs.values(), key=lambda r: len(r.t))
    arrays = {"t": longest.t}
    for name, run in runs.items():
        for key, values in run.series.items():
            padded = np.full((len(longest.t), values.shape[1]), np.nan)
            padded[: len(values)] = values
            arrays[f"{name}/{key}"] = padded
    return arrays


def instability_record(runs: Iterable[RunResult]) -> dict:
    """The `instability` entry of a metrics.json: {label: {"reason", "time_s"}} for each
    run that did not end "ok" (empty when every run is fine).

    Parameters
    ----------
    runs : iterable of RunResult
        The runs.

    Returns
    -------
    dict of str to dict
        Per controller label of an unstable run: "reason" (str) and "time_s", the stop
        time [s] (float or None).
    """
    return {
        run.controller: {"reason": run.reason, "time_s": run.stop_time}
        for run in runs
        if run.status != "ok"
    }
