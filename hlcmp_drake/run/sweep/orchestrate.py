"""`run_sweep`: plan a sweep, skip its finished tasks, run the rest on an engine, and keep
sweep.csv, sweep.json and the plots current."""

from __future__ import annotations

import os
import time
from pathlib import Path

from hlcmp_drake.config.sweep import SweepTask
from hlcmp_drake.io import outputs
from hlcmp_drake.present.progress import SILENT, Progress
from hlcmp_drake.present.sweep import sweep_figures, sweep_table
from hlcmp_drake.run.sweep.engines import (
    _run_local,
    _run_ray,
    _terminate_is_interrupt,
    check_engine,
    cluster_joined,
)
from hlcmp_drake.run.sweep.planning import check_metrics, foreign_task_folders, plan_sweep
from hlcmp_drake.run.sweep.results import (
    PLOTS,
    SweepResult,
    _summary,
    _wall_s,
    _write_tables,
)
from hlcmp_drake.run.sweep.task_results import read_task_results


def run_sweep(
    name_or_path: str | Path,
    out_dir: str | Path | None = None,
    engine: str = "local",
    workers: int | None = None,
    address: str | None = None,
    reporter: Progress = SILENT,
) -> SweepResult:
    """Run every unfinished task of a sweep and write sweep.csv, sweep.json and plots/.

    Parameters
    ----------
    name_or_path : str or Path
        A bundled sweep or a sweep file.
    out_dir : str or Path, optional
        The output folder (default out/sweeps/<sweep name>); task ID runs in OUT/tasks/ID.
    engine : str
        "local" (a process pool) or "ray".
    workers : int, optional
        Tasks run at once. Local default: os.cpu_count() -- each task is one
        single-threaded simulation, so one per core is what a sweep is for; pass fewer on
        a shared machine. Ray default: as many as the Ray instance schedules (a local one
        gets os.cpu_count() CPUs).
    address : str, optional
        Ray only: the cluster to join (e.g. "ray://head:10001" or "auto").
    reporter : Progress, optional
        One line per finished task.

    Returns
    -------
    SweepResult

    Raises
    ------
    InputError
        A bad sweep file or override (file:line), a metric no task will write (checked
        on a short run before any task: `planning.check_metrics`), an unknown engine, Ray
        not installed.
    KeyboardInterrupt
        On Ctrl-C or SIGTERM, after the workers are stopped; every finished task is
        kept and listed in sweep.csv.
    """
    check_engine(engine, workers, address)  # before anything is written
    with cluster_joined(engine, address):  # no cluster at the address: nothing run or written
        start = time.perf_counter()
        plan = plan_sweep(name_or_path, out_dir)
        reporter.say("checking the metrics on a short run of the scenario ...")
        check_metrics(plan)  # a typo stops the sweep here, not after every task
        metrics = plan.sweep.config.metrics
        rows, missing, failed = {}, [], {}

        def failure(task: SweepTask, error: str) -> dict:
            failed[task.id] = error
            return {"status": "error", "values": {}, "wall_s": None, "error": error}

        def finished(task: SweepTask, info: dict | None) -> dict:
            results = read_task_results(task.run_dir, metrics)
            if results is None:  # spoiled since it was planned or written: a rerun runs it
                return failure(task, f"its outputs in {task.run_dir} cannot be read")
            if results.status == "ok":
                missing.extend(
                    f"{label} ({next(m.path or m.series for m in metrics if m.label == label)}): "
                    f"task {task.id}"
                    for label in results.missing
                )
            wall = info["wall_s"] if info else _wall_s(Path(task.run_dir))
            return {"status": results.status, "values": results.values, "wall_s": wall}

        pending = []
        for task in plan.tasks:
            if plan.states[task.id] == "done":
                rows[task.id] = finished(task, None)
            else:
                rows[task.id] = {"status": "pending", "values": {}, "wall_s": None}
                pending.append(task)
        already_done = len(plan.tasks) - len(pending)
        files = _write_tables(plan.out_dir, _summary(plan, rows))
        ran: list = []

        def on_done(task: SweepTask, info: dict | None, error: str | None) -> None:
            ran.append(task.id)
            rows[task.id] = finished(task, info) if error is None else failure(task, error)
            _write_tables(plan.out_dir, _summary(plan, rows))
            row = rows[task.id]
            reporter.say(
                f"[{already_done + len(ran)}/{len(plan.tasks)}] {task.id}: {row['status']}"
                + (f" ({row['error']})" if "error" in row else f", {row['wall_s']:.1f} s")
            )

        if pending:
            # Local default: one worker per CPU. Each task is one single-threaded simulation, so
            # that is the throughput a sweep is for; on a shared machine pass --workers.
            count = workers or os.cpu_count() or 1
            reporter.say(
                f"sweep {plan.sweep.path.stem}: {len(pending)} of {len(plan.tasks)} tasks to run "
                f"({already_done} already done) on the {engine} engine"
                + (
                    f", {min(count, len(pending))} at a time"
                    if engine == "local" or workers
                    else ""
                )
            )
            with _terminate_is_interrupt():
                if engine == "local":
                    _run_local(pending, min(count, len(pending)), on_done)
                else:
                    _run_ray(pending, workers, address, on_done)
        summary = _summary(plan, rows)
        files = _write_tables(plan.out_dir, summary)
        for file_name, figure in sweep_figures(summary).items():
            files.append(outputs.save_figure(plan.out_dir / PLOTS / file_name, figure))
        # Listed as the folder's outputs, so that a plot of a key no longer swept goes.
        outputs.list_outputs(plan.out_dir, files)
        unstable = [task.id for task in plan.tasks if rows[task.id]["status"] == "unstable"]
        stale = sum(1 for state in plan.states.values() if state == "stale")
        return SweepResult(
            summary,
            plan.out_dir,
            sweep_table(summary),
            already_done,
            stale,
            ran,
            failed,
            unstable,
            missing,
            time.perf_counter() - start,
            files,
            foreign_task_folders(plan),
        )
