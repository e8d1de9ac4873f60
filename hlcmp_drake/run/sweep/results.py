"""A sweep's results: each finished task's metric values (read from its run folder),
sweep.json's summary of every task, and sweep.csv."""

from __future__ import annotations

import csv
import dataclasses as dc
import io
import json
from pathlib import Path

from hlcmp_drake.config.sweep import CASE
from hlcmp_drake.experiments.table import Table
from hlcmp_drake.io import outputs
from hlcmp_drake.run.sweep.planning import SweepPlan

PLOTS = "plots"  # the folder of a sweep's plots in its output folder


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

    @property
    def plots(self) -> list:
        """The plots among `files` (in OUT/plots): none for a sweep without parameters."""
        return [file for file in self.files if Path(file).parent == Path(self.out_dir) / PLOTS]


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
