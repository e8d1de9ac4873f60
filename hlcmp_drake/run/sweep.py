"""Running a sweep (`hlcmp sweep`): plan its tasks, skip the finished ones, run the rest on
an engine, and keep sweep.csv, sweep.json and one plot per swept parameter current.

A task is finished when its run folder OUT/tasks/ID holds a metrics.json (written last and
atomically by the runner) beside a scenario.yaml equal to the task's scenario; a folder
whose scenario.yaml differs (the sweep or its scenario was edited since) runs again.
sweep.csv and sweep.json are rewritten atomically after every finished task, so an
interrupted sweep loses none, and the same command again runs only what is missing.

Engines. `local` (the default, nothing extra needed): a `concurrent.futures`
ProcessPoolExecutor whose workers are started with 'spawn' (pydrake and fork do not mix).
`ray` (``pip install -e '.[ray]'``): a Ray task per sweep task, on a local Ray instance or
on the cluster at `address`; the worker returns the run folder's files and this process
writes them, so the nodes need the package installed but no shared file system. Either
way a task travels as plain text (its scenario's YAML and its overrides) and each worker
builds its own diagram.
"""

from __future__ import annotations

import contextlib
import csv
import ctypes
import dataclasses as dc
import io
import json
import logging
import multiprocessing
import os
import signal
import sys
import tempfile
import threading
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Callable

import numpy as np

from hlcmp_drake.config.loading import load_scenario_text
from hlcmp_drake.config.sweep import CASE, Sweep, SweepMetric, SweepTask, load_sweep, plan_tasks
from hlcmp_drake.experiments.table import Table
from hlcmp_drake.io import outputs
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.present.progress import SILENT, Progress
from hlcmp_drake.present.sweep import sweep_figures, sweep_table
from hlcmp_drake.run.runner import run_loaded_scenario

ENGINES = ("local", "ray")
FINISHED = ("ok", "unstable")


@dc.dataclass
class SweepPlan:
    """A sweep's tasks and where each stands, before anything runs.

    Attributes
    ----------
    sweep : Sweep
    out_dir : Path
    tasks : list of SweepTask
    states : dict of str to str
        By task id: "done" (finished, same scenario), "stale" (finished with another
        scenario: runs again) or "pending".
    """

    sweep: Sweep
    out_dir: Path
    tasks: list
    states: dict


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


def default_out_dir(sweep: Sweep) -> Path:
    """out/sweeps/<sweep file's name>.

    Parameters
    ----------
    sweep : Sweep
    """
    return Path("out") / "sweeps" / sweep.path.stem


def task_state(task: SweepTask) -> str:
    """ "done", "stale" or "pending" (see `SweepPlan`).

    Parameters
    ----------
    task : SweepTask
    """
    run_dir = Path(task.run_dir)
    if not (run_dir / "metrics.json").is_file():
        return "pending"
    try:
        same = (run_dir / "scenario.yaml").read_text() == task.scenario_yaml
    except (OSError, UnicodeDecodeError):
        same = False
    return "done" if same else "stale"


def plan_sweep(name_or_path: str | Path, out_dir: str | Path | None = None) -> SweepPlan:
    """Load a sweep file, plan its tasks and see which are finished (nothing is written).

    Parameters
    ----------
    name_or_path : str or Path
        A bundled sweep (diagrams/sweeps/NAME.yaml) or a sweep file.
    out_dir : str or Path, optional
        The sweep's output folder (default out/sweeps/<sweep name>).

    Returns
    -------
    SweepPlan

    Raises
    ------
    InputError
        For any problem of the sweep file or of a task's overrides (file:line).
    """
    sweep = load_sweep(name_or_path)
    out_dir = Path(out_dir) if out_dir is not None else default_out_dir(sweep)
    tasks = plan_tasks(sweep, out_dir)
    return SweepPlan(sweep, out_dir, tasks, {task.id: task_state(task) for task in tasks})


# --- one task, in whatever process runs it -------------------------------------------


def run_task(task: SweepTask) -> dict:
    """Run one task in this process: its scenario.yaml first, then the runner's files
    (metrics.json last), then sweep_task.json (id, values, status, wall time).

    Parameters
    ----------
    task : SweepTask

    Returns
    -------
    dict
        The sweep_task.json content.
    """
    run_dir = Path(task.run_dir)
    (run_dir / "metrics.json").unlink(
        missing_ok=True
    )  # an old result never passes for this scenario's
    outputs.write_text(run_dir / "scenario.yaml", task.scenario_yaml)
    start = time.perf_counter()
    scenario = load_scenario_text(task.scenario_yaml, task.scenario_path)
    scenario.controllers = {label: scenario.controllers[label] for label in task.controllers}
    result = run_loaded_scenario(scenario, task.scenario_path, run_dir, claims=task.claims)
    info = {
        "id": task.id,
        "parameters": task.parameters,
        "repetition": task.repetition,
        "overrides": task.overrides,
        "status": result.metrics["status"],
        "wall_s": round(time.perf_counter() - start, 3),
    }
    outputs.write_json(run_dir / "sweep_task.json", info)
    return info


def run_task_returning_files(task: SweepTask) -> tuple[dict, dict]:
    """Run one task in a temporary folder and return its files (for a node that does
    not share the sweep's file system).

    Parameters
    ----------
    task : SweepTask

    Returns
    -------
    (dict, dict of str to bytes)
        The sweep_task.json content, and every file of the run folder by relative path.
    """
    _quiet_drake()
    with tempfile.TemporaryDirectory(prefix="hlcmp-sweep-") as temp:
        info = run_task(dc.replace(task, run_dir=temp))
        files = {
            str(p.relative_to(temp)): p.read_bytes()
            for p in sorted(Path(temp).rglob("*"))
            if p.is_file()
        }
    return info, files


def store_files(run_dir: str | Path, files: dict) -> None:
    """Write a run folder's files returned by a remote worker, each atomically, in the
    order that keeps the finished-task rule: any old metrics.json goes first,
    metrics.json and sweep_task.json come last.

    Parameters
    ----------
    run_dir : str or Path
        The task's run folder.
    files : dict of str to bytes
        By path relative to the run folder.
    """
    run_dir = Path(run_dir)
    (run_dir / "metrics.json").unlink(missing_ok=True)
    last = ("metrics.json", "sweep_task.json")
    for name in sorted(files, key=lambda n: (n in last, last.index(n) if n in last else 0, n)):
        data = files[name]
        outputs.atomic_write(run_dir / name, lambda temp, data=data: Path(temp).write_bytes(data))


def _quiet_drake() -> None:
    """Drake's INFO lines (a recording's Meshcat server) are not for a sweep's terminal."""
    import pydrake  # noqa: F401  (pydrake sets its logger's level when imported)

    logging.getLogger("drake").setLevel(logging.WARNING)


def _local_worker_init(parent: int) -> None:
    """In each local worker: Ctrl-C is the parent's to handle (it stops the workers); and
    the worker ends with the sweep's process `parent`, even one killed outright, so no
    orphan goes on running tasks that a re-run would start again."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _end_with_parent(parent)
    _quiet_drake()


def _end_with_parent(parent: int) -> None:
    """Linux: ask the kernel for SIGTERM when the parent dies (prctl PR_SET_PDEATHSIG), then
    make sure it had not died already. Elsewhere, nothing: an orphan finishes its tasks."""
    if not sys.platform.startswith("linux"):
        return
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGTERM)  # 1: PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if os.getppid() != parent:
        os._exit(1)


# --- engines -------------------------------------------------------------------------

Done = Callable[[SweepTask, "dict | None", "str | None"], None]


def _run_local(tasks: list, workers: int, on_done: Done) -> None:
    """A spawn-started process pool; each result is handed to `on_done` as it finishes.
    An interrupt cancels the queue and terminates the workers (their tasks are not
    finished, so a re-run does them)."""
    executor = ProcessPoolExecutor(
        max_workers=workers,
        mp_context=multiprocessing.get_context("spawn"),
        initializer=_local_worker_init,
        initargs=(os.getpid(),),
    )
    try:
        futures = {executor.submit(run_task, task): task for task in tasks}
        for future in as_completed(futures):
            try:
                info, error = future.result(), None
            except (
                BrokenProcessPool
            ) as failure:  # a worker died (killed, out of memory): so did the pool
                info, error = None, f"a worker process died ({failure})"
            except Exception as failure:  # the task's own error: record it, go on
                info, error = None, f"{type(failure).__name__}: {failure}"
            on_done(futures[future], info, error)
    except BaseException:
        _stop_pool(executor)
        raise
    executor.shutdown()


def _stop_pool(executor: ProcessPoolExecutor) -> None:
    processes = list((getattr(executor, "_processes", None) or {}).values())
    executor.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.terminate()
    for process in processes:
        process.join(timeout=5)


def _import_ray():
    try:
        import ray
    except ImportError:
        raise InputError(
            "--engine ray needs Ray, which is not installed: pip install -e '.[ray]'"
        ) from None
    return ray


def _run_ray(tasks: list, workers: int | None, address: str | None, on_done: Done) -> None:
    """One Ray task per sweep task (one CPU each), at most `workers` in flight."""
    ray = _import_ray()
    started = not ray.is_initialized()
    if started:
        options = (
            {"address": address}
            if address
            else {"num_cpus": workers or os.cpu_count() or 1, "include_dashboard": False}
        )
        try:
            ray.init(logging_level=logging.WARNING, **options)
        except ConnectionError as error:
            raise InputError(
                f"--address {address}: cannot join a Ray cluster there ({error})"
            ) from None
    remote = ray.remote(num_cpus=1)(run_task_returning_files)
    queue, in_flight = list(tasks), {}
    limit = workers or len(tasks)
    try:
        while queue or in_flight:
            while queue and len(in_flight) < limit:
                task = queue.pop(0)
                in_flight[remote.remote(task)] = task
            (ref,), _ = ray.wait(list(in_flight), num_returns=1)
            task = in_flight.pop(ref)
            try:
                info, files = ray.get(ref)
            except Exception as failure:  # RayTaskError wraps the task's own error
                on_done(task, None, " ".join(str(failure).split())[-400:])
                continue
            store_files(task.run_dir, files)
            on_done(task, info, None)
    except BaseException:
        for ref in in_flight:
            ray.cancel(ref, force=True)
        raise
    finally:
        if started:
            ray.shutdown()


@contextlib.contextmanager
def _terminate_is_interrupt():
    """While the sweep runs, SIGTERM (`kill`) stops it like Ctrl-C: the workers are
    stopped and every finished task is kept."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


# --- results -------------------------------------------------------------------------


def _lookup(data: object, dotted: str) -> tuple[bool, object]:
    """(found, value) of a dotted path into nested dicts; a key may hold dots."""
    parts, node, i = dotted.split("."), data, 0
    while i < len(parts):
        if not isinstance(node, dict):
            return False, None
        for j in range(len(parts), i, -1):
            if ".".join(parts[i:j]) in node:
                node, i = node[".".join(parts[i:j])], j
                break
        else:
            return False, None
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


def task_values(run_dir: str | Path, metrics: list) -> tuple[dict, list]:
    """A finished task's metric values, read from its run folder.

    Parameters
    ----------
    run_dir : str or Path
        Holds metrics.json and timeseries.npz.
    metrics : list of SweepMetric

    Returns
    -------
    (dict, list of str)
        {label: value (scaled; yes/no where `below` is set; None when null)}, and the
        labels of the metrics that were not found there.
    """
    run_dir = Path(run_dir)
    data = json.loads((run_dir / "metrics.json").read_text())
    values, missing = {}, []
    arrays = np.load(run_dir / "timeseries.npz") if any(m.series for m in metrics) else None
    try:
        for metric in metrics:
            found, value = _lookup(data, metric.path) if metric.path else _reduce(arrays, metric)
            if not found:
                missing.append(metric.label)
            values[metric.label] = _finish(value, metric) if found else None
    finally:
        if arrays is not None:
            arrays.close()
    return values, missing


def _wall_s(run_dir: Path) -> float | None:
    try:
        return json.loads((run_dir / "sweep_task.json").read_text()).get("wall_s")
    except (OSError, ValueError):
        return None


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
        A bad sweep file or override (file:line), an unknown engine, Ray not installed.
    KeyboardInterrupt
        On Ctrl-C or SIGTERM, after the workers are stopped; every finished task is
        kept and listed in sweep.csv.
    """
    if engine not in ENGINES:
        raise InputError(f"--engine: must be one of {', '.join(ENGINES)}, got '{engine}'")
    if address and engine != "ray":
        raise InputError("--address: joins a Ray cluster, so it needs --engine ray")
    if workers is not None and workers < 1:
        raise InputError(f"--workers: must be at least 1, got {workers}")
    if engine == "ray":
        _import_ray()  # before anything is written
    start = time.perf_counter()
    plan = plan_sweep(name_or_path, out_dir)
    metrics = plan.sweep.config.metrics
    rows, missing = {}, []

    def finished(task: SweepTask, info: dict | None) -> dict:
        values, absent = task_values(task.run_dir, metrics)
        status = json.loads((Path(task.run_dir) / "metrics.json").read_text())["status"]
        if status == "ok":
            missing.extend(
                f"{label} ({next(m.path or m.series for m in metrics if m.label == label)}): "
                f"task {task.id}"
                for label in absent
            )
        wall = info["wall_s"] if info else _wall_s(Path(task.run_dir))
        return {"status": status, "values": values, "wall_s": wall}

    pending = []
    for task in plan.tasks:
        if plan.states[task.id] == "done":
            rows[task.id] = finished(task, None)
        else:
            rows[task.id] = {"status": "pending", "values": {}, "wall_s": None}
            pending.append(task)
    already_done = len(plan.tasks) - len(pending)
    files = _write_tables(plan.out_dir, _summary(plan, rows))
    ran, failed = [], {}

    def on_done(task: SweepTask, info: dict | None, error: str | None) -> None:
        ran.append(task.id)
        if error is None:
            rows[task.id] = finished(task, info)
        else:
            failed[task.id] = error
            rows[task.id] = {"status": "error", "values": {}, "wall_s": None, "error": error}
        _write_tables(plan.out_dir, _summary(plan, rows))
        row = rows[task.id]
        reporter.say(
            f"[{already_done + len(ran)}/{len(plan.tasks)}] {task.id}: {row['status']}"
            + (f" ({error})" if error else f", {row['wall_s']:.1f} s")
        )

    if pending:
        # Local default: one worker per CPU. Each task is one single-threaded simulation, so
        # that is the throughput a sweep is for; on a shared machine pass --workers.
        count = workers or os.cpu_count() or 1
        reporter.say(
            f"sweep {plan.sweep.path.stem}: {len(pending)} of {len(plan.tasks)} tasks to run "
            f"({already_done} already done) on the {engine} engine"
            + (f", {min(count, len(pending))} at a time" if engine == "local" or workers else "")
        )
        with _terminate_is_interrupt():
            if engine == "local":
                _run_local(pending, min(count, len(pending)), on_done)
            else:
                _run_ray(pending, workers, address, on_done)
    summary = _summary(plan, rows)
    files = _write_tables(plan.out_dir, summary)
    for file_name, figure in sweep_figures(summary).items():
        files.append(outputs.save_figure(plan.out_dir / "plots" / file_name, figure))
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
    )
