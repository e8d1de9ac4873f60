"""A sweep task's outputs as the sweep reads them: its status and metric values from its
run folder's metrics.json and timeseries.npz, and the rule that a task whose files cannot
be read is not finished (`read_task_results`, which planning and the orchestration use)."""

from __future__ import annotations

import dataclasses as dc
import json
import zipfile
import zlib
from pathlib import Path

import numpy as np
from numpy.lib.npyio import NpzFile

from hlcmp_drake.config.sweep import SweepMetric

# The statuses of a task that ran to its end (its metrics.json says which).
FINISHED = ("ok", "unstable")


def path_step(node: object, parts: list, i: int) -> tuple[object, int] | None:
    """One step of a dotted path into metrics.json: below `node`, the value that
    parts[i:] begins with and the index of the part after it; None when there is none.

    A dict's key may hold dots (a label such as "vic_fd_0.5"): the longest key that
    matches is taken. A list's element is named by its index from 0 (a per-axis list, e.g.
    "max_abs_torque_Nm.2").

    Parameters
    ----------
    node : object
        A dict, a list or a single value of metrics.json.
    parts : list of str
        The path split at its dots.
    i : int
        The first part still to follow.

    Returns
    -------
    (object, int) or None
    """
    if isinstance(node, dict):
        for j in range(len(parts), i, -1):
            if ".".join(parts[i:j]) in node:
                return node[".".join(parts[i:j])], j
    elif isinstance(node, list) and parts[i].isdigit() and int(parts[i]) < len(node):
        return node[int(parts[i])], i + 1
    return None


def _lookup(data: object, dotted: str) -> tuple[bool, object]:
    """(found, value) of a dotted path into nested dicts and lists (`path_step`)."""
    parts, node, i = dotted.split("."), data, 0
    while i < len(parts):
        step = path_step(node, parts, i)
        if step is None:
            return False, None
        node, i = step
    return not isinstance(node, (dict, list)), node


def _reduce(arrays: object, metric: SweepMetric) -> tuple[bool, object]:
    if metric.series not in arrays.files:
        return False, None
    values = np.asarray(arrays[metric.series], dtype=float)
    values = values[:, None] if values.ndim == 1 else values
    if metric.column >= values.shape[1]:
        return False, None
    t, x = np.asarray(arrays["t"]), values[:, metric.column]
    keep = np.isfinite(x)
    if metric.window_s:
        keep &= (t >= metric.window_s[0]) & (t <= metric.window_s[1])
    if not keep.any():
        return True, None
    x = x[keep]
    reduce = {
        "max": np.max,
        "min": np.min,
        "max_abs": lambda v: np.max(np.abs(v)),
        "mean": np.mean,
        "final": lambda v: v[-1],
    }[metric.reduce]
    return True, float(reduce(x))


def _finish(value: object, metric: SweepMetric) -> object:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        value = float(value) * metric.scale
        return bool(value < metric.below) if metric.below is not None else value
    return value


@dc.dataclass
class TaskResults:
    """A finished task's outputs, as a sweep reads them from its run folder.

    Attributes
    ----------
    status : str
        One of FINISHED.
    values : dict
        {label: value (scaled; yes/no where `below` is set; None when null)}.
    missing : list of str
        The labels of the metrics that were not found there.
    """

    status: str
    values: dict
    missing: list


# What reading a run folder's files raises when one is missing, cut short or not what the
# runner writes (a hand-edited or half-copied folder); zlib's: timeseries.npz is compressed.
UNREADABLE = (OSError, EOFError, ValueError, KeyError, zipfile.BadZipFile, zlib.error)


def read_task_results(run_dir: str | Path, metrics: list) -> TaskResults | None:
    """A finished task's status and metric values, read from its run folder.

    This is the sweep's rule for a finished task (`planning.task_state`): one whose files
    cannot be read is not finished, and runs again.

    Parameters
    ----------
    run_dir : str or Path
        Holds metrics.json and timeseries.npz.
    metrics : list of SweepMetric

    Returns
    -------
    TaskResults or None
        None when metrics.json, or timeseries.npz for a `series` metric, is missing or
        unreadable, or metrics.json gives no finished status.
    """
    run_dir = Path(run_dir)
    try:
        data = json.loads((run_dir / "metrics.json").read_text())
        if not isinstance(data, dict) or data.get("status") not in FINISHED:
            return None
        values, missing = {}, []
        arrays = np.load(run_dir / "timeseries.npz") if any(m.series for m in metrics) else None
        if arrays is not None and not isinstance(arrays, NpzFile):
            return None  # one array (an .npy's contents), not the runner's named ones
        try:
            for metric in metrics:
                found, value = (
                    _lookup(data, metric.path) if metric.path else _reduce(arrays, metric)
                )
                if not found:
                    missing.append(metric.label)
                values[metric.label] = _finish(value, metric) if found else None
        finally:
            if arrays is not None:
                arrays.close()
    except UNREADABLE:
        return None
    return TaskResults(data["status"], values, missing)
