"""A sweep's plan: its tasks from the sweep file, and which of them are finished already
(the resumability rule of `hlcmp_drake.run.sweep`)."""

from __future__ import annotations

import dataclasses as dc
from pathlib import Path

from hlcmp_drake.config.sweep import Sweep, SweepTask, load_sweep, plan_tasks


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
