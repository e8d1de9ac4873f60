"""A sweep's results: each finished task's metric values (read from its run folder),
sweep.json's summary of every task, and sweep.csv."""

from __future__ import annotations

import csv
import dataclasses as dc
import io
import json
import zipfile
import zlib
from pathlib import Path

import numpy as np
from numpy.lib.npyio import NpzFile

from hlcmp_drake.config.sweep import CASE, SweepMetric
from hlcmp_drake.experiments.table import Table
from hlcmp_drake.io import outputs
from hlcmp_drake.run.sweep.planning import SweepPlan, path_step

FINISHED = ("ok", "unstable")


@dc.dataclass
class SweepResult:
    """What `run_sweep` returns.

    Attributes
    ----------
    summary : dict
        The sweep.json content.
    out_dir : Path
    table : Table
        The finished tasks (see `present.sweep.sweep_table`).
    already_done : int
        Tasks that were finished before this call (skipped).
    stale : int
        Tasks whose earlier result was for another scenario text (run again).
    ran : list of str
        The ids run by this call (failed ones included).
    failed : dict of str to str
        Id -> error message, for tasks that raised (not finished: a re-run retries them).
    unstable : list of str
        Ids whose runs went unstable (finished; metrics.json says where and why).
    missing : list of str
        Metrics not found in an ok task's output ("LABEL (PATH): task ID").
    wall_s : float
    files : list of Path
        sweep.csv, sweep.json and the plots.
    foreign : list of str
        The folders in OUT/tasks that are no task of this sweep (`foreign_task_folders`).
    """

    summary: dict
    out_dir: Path
    table: Table
    already_done: int
    stale: int
    ran: list
    failed: dict
    unstable: list
    missing: list
    wall_s: float
    files: list
    foreign: list


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


def _wall_s(run_dir: Path) -> float | None:
    try:
        record = json.loads((run_dir / "sweep_task.json").read_text())
    except (OSError, ValueError):
        return None
    wall = record.get("wall_s") if isinstance(record, dict) else None
    return wall if isinstance(wall, (int, float)) and not isinstance(wall, bool) else None


def _summary(plan: SweepPlan, rows: dict) -> dict:
    sweep, config = plan.sweep, plan.sweep.config
    labels = {CASE: "case", **config.labels}
    counts = {
        state: sum(1 for t in plan.tasks if rows[t.id]["status"] == state)
        for state in ("ok", "unstable", "error", "pending")
    }
    return {
        "name": sweep.path.stem,
        "sweep": str(sweep.path),
        "scenario": str(sweep.scenario_path),
        "repetitions": config.repetitions,
        "controllers": plan.tasks[0].controllers if plan.tasks else [],
        "parameters": [{"key": key, "label": labels.get(key, key)} for key in sweep.parameters],
        "metrics": [
            {
                "label": m.label,
                "path": m.path,
                "series": m.series,
                "digits": m.digits,
                "missing": m.missing,
                "yes_no": m.below is not None,
            }
            for m in config.metrics
        ],
        "tasks": [
            {
                "id": t.id,
                "parameters": t.parameters,
                "repetition": t.repetition,
                **rows[t.id],
                "run_dir": str(Path("tasks") / t.id),
            }
            for t in plan.tasks
        ],
        "counts": {"tasks": len(plan.tasks), **counts},
    }


def _csv(summary: dict) -> str:
    keys = [p["key"] for p in summary["parameters"]]
    labels = [m["label"] for m in summary["metrics"]]
    stream = io.StringIO()
    writer = csv.writer(stream, lineterminator="\n")
    writer.writerow(["id", *keys, "repetition", "status", *labels, "wall_s"])

    def text(value):
        if value is None:
            return ""
        return str(value).lower() if isinstance(value, bool) else value

    for task in summary["tasks"]:
        writer.writerow(
            [
                task["id"],
                *(task["parameters"][k] for k in keys),
                task["repetition"],
                task["status"],
                *(text(task["values"].get(label)) for label in labels),
                text(task["wall_s"]),
            ]
        )
    return stream.getvalue()


def _write_tables(out_dir: Path, summary: dict) -> list:
    return [
        outputs.write_text(out_dir / "sweep.csv", _csv(summary)),
        outputs.write_json(out_dir / "sweep.json", summary),
    ]
