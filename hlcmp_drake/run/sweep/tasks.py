"""One sweep task, in whatever process runs it: in the sweep's file system (a local
worker) or in a temporary folder whose files go back to the sweep (a Ray worker)."""

from __future__ import annotations

import dataclasses as dc
import logging
import tempfile
import time
from pathlib import Path
from typing import Any, Callable

from hlcmp_drake.config.loading import load_scenario_text
from hlcmp_drake.config.sweep import INPUTS_FILE, SweepTask
from hlcmp_drake.io import outputs
from hlcmp_drake.run.runner import run_loaded_scenario


def ran_with(run_dir: Path, scenario_yaml: str, inputs_digest: str) -> bool:
    """Whether a run folder's scenario.yaml is `scenario_yaml` and the files it names had
    the contents `inputs_digest` says (its inputs.sha256; a folder written before the
    digest was kept is judged by its text alone).

    Parameters
    ----------
    run_dir : Path
    scenario_yaml : str
    inputs_digest : str
        `config.world.inputs_digest` of the scenario now.

    Returns
    -------
    bool
    """
    try:
        if (run_dir / "scenario.yaml").read_text() != scenario_yaml:
            return False
        inputs = run_dir / INPUTS_FILE
        return not inputs.is_file() or inputs.read_text().strip() == inputs_digest
    except (OSError, UnicodeDecodeError):
        return False


def run_task(task: SweepTask) -> dict:
    """Run one task in this process: its scenario.yaml and inputs.sha256 first, then the
    runner's files (metrics.json last), then sweep_task.json (id, values, status, wall
    time).

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
    outputs.write_text(run_dir / INPUTS_FILE, task.inputs_digest + "\n")
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
    return run_in_temporary_folder(run_task, task)


def run_in_temporary_folder(function: Callable, task: Any) -> tuple[dict, dict]:
    """`function(task)` with the task's run folder a temporary one, and that folder's files.

    Parameters
    ----------
    function : callable(task) -> dict
        Runs a task into its `run_dir` (`run_task`, a library's skill).
    task : dataclass with a `run_dir`

    Returns
    -------
    (dict, dict of str to bytes)
        What `function` returned, and every file of the run folder by relative path.
    """
    quiet_drake()
    with tempfile.TemporaryDirectory(prefix="hlcmp-task-") as temp:
        info = function(dc.replace(task, run_dir=temp))
        files = {
            str(p.relative_to(temp)): p.read_bytes()
            for p in sorted(Path(temp).rglob("*"))
            if p.is_file()
        }
    return info, files


def store_files(run_dir: str | Path, files: dict) -> None:
    """Write a run folder's files returned by a remote worker, each atomically, in the
    order that keeps the finished-task rule: any old metrics.json and task record go first, then
    everything else, then metrics.json, and the task's record (NAME_task.json) last.

    Parameters
    ----------
    run_dir : str or Path
        The task's run folder.
    files : dict of str to bytes
        By path relative to the run folder.
    """
    run_dir = Path(run_dir)
    for name in ["metrics.json", *(n for n in files if n.endswith("_task.json"))]:
        (run_dir / name).unlink(missing_ok=True)

    def order(name):
        return (name == "metrics.json") + 2 * name.endswith("_task.json"), name

    for name in sorted(files, key=order):
        data = files[name]
        outputs.atomic_write(run_dir / name, lambda temp, data=data: Path(temp).write_bytes(data))


def quiet_drake() -> None:
    """Drake's INFO lines (a recording's Meshcat server) are not for a sweep's or a
    report's terminal."""
    import pydrake  # noqa: F401  (pydrake sets its logger's level when imported)

    logging.getLogger("drake").setLevel(logging.WARNING)
