"""A sweep's plan: its tasks from the sweep file, which of them are finished already (the
resumability rule of `hlcmp_drake.run.sweep`), and its metrics checked against what the
tasks will write (`check_metrics`) before any of them runs."""

from __future__ import annotations

import dataclasses as dc
import difflib
from pathlib import Path

from hlcmp_drake.config.sweep import (
    Sweep,
    SweepMetric,
    SweepTask,
    load_sweep,
    metric_line,
    plan_tasks,
)
from hlcmp_drake.io.errors import located
from hlcmp_drake.run.sweep.task_results import path_step, read_task_results
from hlcmp_drake.run.sweep.tasks import ran_with

# The short run `check_metrics` makes of a task's scenario: this many log samples.
CHECK_RUN_SAMPLES = 5


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
        scenario: runs again) or "pending" (not run, or its outputs are missing or
        unreadable: runs again).
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


def task_state(task: SweepTask, metrics: list) -> str:
    """ "done", "stale" or "pending" (see `SweepPlan`): a task whose metrics.json or
    timeseries.npz is missing or unreadable (`task_results.read_task_results`) is pending.

    Parameters
    ----------
    task : SweepTask
    metrics : list of SweepMetric
        The sweep's metrics: what must be readable in the task's outputs.
    """
    run_dir = Path(task.run_dir)
    if read_task_results(run_dir, metrics) is None:
        return "pending"
    return "done" if ran_with(run_dir, task.scenario_yaml, task.inputs_digest) else "stale"


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
    states = {task.id: task_state(task, sweep.config.metrics) for task in tasks}
    return SweepPlan(sweep, out_dir, tasks, states)


def foreign_task_folders(plan: SweepPlan) -> list[str]:
    """The folders in OUT/tasks that are no task of this sweep (an earlier version of its
    grid's, or another sweep's given the same --out): a sweep never deletes them, and its
    tables leave them out.

    Parameters
    ----------
    plan : SweepPlan

    Returns
    -------
    list of str
        Their names, sorted.
    """
    folder = plan.out_dir / "tasks"
    ids = {task.id for task in plan.tasks}
    if not folder.is_dir():
        return []
    return sorted(p.name for p in folder.iterdir() if p.is_dir() and p.name not in ids)


@dc.dataclass
class TaskOutputs:
    """What a task's run folder will hold, as far as a sweep's metrics read it.

    Attributes
    ----------
    metrics : dict
        metrics.json of a short run of the task's scenario (its keys, not its values).
    series : dict of str to int
        timeseries.npz's "CONTROLLER/NAME" arrays -> their number of columns.
    learners : list of str
        The learners the claims are judged for; empty when the task judges no claim.
    claims : list of str or None
        The experiment's claim names (None: not known).
    left_out : list of str
        The scenario's controllers the sweep's `controllers` leaves out (not run).
    """

    metrics: dict
    series: dict
    learners: list
    claims: list | None
    left_out: list = dc.field(default_factory=list)


def task_outputs(task: SweepTask) -> TaskOutputs:
    """Run the task's scenario for CHECK_RUN_SAMPLES log samples (nothing is written) and
    see what its metrics.json and timeseries.npz hold.

    Parameters
    ----------
    task : SweepTask

    Returns
    -------
    TaskOutputs
    """
    from hlcmp_drake.config.loading import load_scenario, load_scenario_text
    from hlcmp_drake.experiments import claim_names, experiment_of
    from hlcmp_drake.run.runner import evaluate, run_controllers, without_claims
    from hlcmp_drake.worlds.controllers import learners

    every, _ = load_scenario(task.scenario_path, task.overrides)  # before `controllers` keeps some
    scenario = load_scenario_text(task.scenario_yaml, task.scenario_path)
    scenario.controllers = {label: scenario.controllers[label] for label in task.controllers}
    experiment = experiment_of(scenario, task.scenario_path)
    short = dc.replace(
        scenario,
        duration_s=min(scenario.duration_s, CHECK_RUN_SAMPLES * scenario.log_period_s),
    )
    runs = run_controllers(short)
    series = {
        f"{label}/{name}": (values.shape[1] if values.ndim > 1 else 1)
        for label, run in runs.items()
        for name, values in run.series.items()
    }
    return TaskOutputs(
        evaluate(runs, short, without_claims(experiment)),
        series,
        learners(scenario) if task.claims else [],
        claim_names(experiment),
        [label for label in every.controllers if label not in task.controllers],
    )


def _names(node: dict) -> str:
    return ", ".join(node) or "nothing"


def _left_out(label: str, running: list) -> str:
    """That a controller the sweep leaves out does not run, and which run."""
    kept = _names(running)
    return f"'{label}' does not run: the sweep's `controllers` leaves it out (it runs {kept})"


def _controller_problem(outputs: TaskOutputs, rest: str) -> str | None:
    """None when a path's `rest` (after `controllers.` or `instability.`) begins with a
    controller that runs; else that it is one the sweep leaves out (`TaskOutputs.left_out`),
    or that the scenario has none such, naming its controllers (those that run, then those
    left out) and the nearest one. A label may hold dots (vic_fd_1.5), so the longest of the
    labels `rest` begins with is the one it names (vic_fd_1.5, not vic_fd_1)."""
    running = list(outputs.metrics["controllers"])
    every = running + [n for n in outputs.left_out if n not in running]
    named = [n for n in every if rest == n or rest.startswith(n + ".")]
    if named:
        label = max(named, key=len)
        return None if label in running else _left_out(label, running)
    asked = rest.split(".")[0]
    nearest = difflib.get_close_matches(asked, every, n=1)
    hint = f"; did you mean '{nearest[0]}'?" if nearest else ""
    return f"the scenario has no controller '{asked}' (its controllers: {_names(every)}{hint})"


def _walk(node: object, dotted: str) -> str | None:
    """None when the dotted path names one value in `node` (step by step as
    `path_step` reads it, and `results._lookup`); else what is wrong."""
    parts, i, where = dotted.split("."), 0, []
    while i < len(parts):
        step = path_step(node, parts, i)
        here = ".".join(where) or "metrics.json"
        if step is None and isinstance(node, dict):
            return f"{here} has no '{parts[i]}' ({_names(node)})"
        if step is None and isinstance(node, list):
            last = len(node) - 1
            return f"{here} is a list of {len(node)}: '{parts[i]}' is no index of it (0 to {last})"
        if step is None:
            return f"{here} is a single value, it has no '{'.'.join(parts[i:])}'"
        node, j = step
        where.append(".".join(parts[i:j]))
        i = j
    if isinstance(node, dict):
        return f"{dotted} is a group ({_names(node)}), not one value"
    if isinstance(node, list):
        return f"{dotted} is a list of {len(node)} values: name one by its index ({dotted}.0)"
    return None


def path_problem(outputs: TaskOutputs, path: str) -> str | None:
    """What is wrong with a metric's `path` into a task's metrics.json, or None.

    A claim's entry is checked down to the claim's name (its parts and details depend on
    the run); `instability` down to the controller (it is there only for a run that went
    unstable).

    Parameters
    ----------
    outputs : TaskOutputs
    path : str
        A dotted path, e.g. "controllers.hlcmp.reach_time_s".

    Returns
    -------
    str or None
    """
    head, _, rest = path.partition(".")
    if head == "claims":
        if not outputs.learners:
            return "claims: this sweep's tasks judge no claim (they keep only some controllers)"
        learner = next((n for n in outputs.learners if rest == n or rest.startswith(n + ".")), "")
        if not learner:
            return (
                f"claims has no '{rest.split('.')[0]}' (the learners: {_names(outputs.learners)})"
            )
        claim = rest[len(learner) + 1 :].split(".")[0]
        if outputs.claims is not None and claim not in outputs.claims:
            return f"claims.{learner} has no '{claim}' ({_names(outputs.claims)})"
        return None
    if head in ("controllers", "instability") and rest:
        problem = _controller_problem(outputs, rest)
        if problem or head == "instability":
            return problem
    known = {k: v for k, v in outputs.metrics.items() if k not in ("claims", "instability")}
    return _walk({**known, "claims": {}, "instability": {}} if head not in known else known, path)


def series_problem(outputs: TaskOutputs, metric: SweepMetric) -> str | None:
    """What is wrong with a metric's `series` and `column`, or None.

    Parameters
    ----------
    outputs : TaskOutputs
    metric : SweepMetric

    Returns
    -------
    str or None
    """
    controller, _, name = metric.series.partition("/")
    names = [key.split("/", 1)[1] for key in outputs.series if key.startswith(controller + "/")]
    if not names and controller in outputs.left_out:
        return _left_out(controller, list(outputs.metrics["controllers"]))
    if not names:
        labels = list(dict.fromkeys(key.split("/", 1)[0] for key in outputs.series))
        return f"no controller '{controller}' runs in the tasks ({_names(labels)})"
    columns = outputs.series.get(metric.series)
    if columns is None:
        return f"{controller} logs no '{name}' ({_names(names)})"
    if metric.column >= columns:
        return f"column {metric.column}: {metric.series} has {columns} column(s)"
    return None


def check_metrics(plan: SweepPlan) -> None:
    """Check every metric's path and series against what the tasks will write, on a short
    run (`task_outputs`) of one task per set of controller kinds, before any task runs. A
    metric that no task's outputs hold is an error; one that only some hold is left to
    each task's results (`hlcmp sweep` lists them as not found).

    Parameters
    ----------
    plan : SweepPlan

    Raises
    ------
    InputError
        ``sweep.yaml:LINE: metrics: entry K: ...``, naming the entry's line, what is
        wrong and what is there instead.
    """
    from hlcmp_drake.config.loading import load_scenario_text

    if not plan.sweep.config.metrics or not plan.tasks:
        return
    kinds = {}
    longest = 0.0  # the longest task's run [s]
    for task in plan.tasks:  # one short run per set of controller kinds
        scenario = load_scenario_text(task.scenario_yaml, task.scenario_path)
        key = tuple((label, type(scenario.controllers[label])) for label in task.controllers)
        kinds.setdefault(key, task)
        longest = max(longest, scenario.duration_s)
    for index, metric in enumerate(plan.sweep.config.metrics):
        if metric.series and metric.window_s and metric.window_s[0] >= longest:
            raise located(
                plan.sweep.path,
                metric_line(plan.sweep, index),
                f"metrics: entry {index + 1}: window_s {metric.window_s} begins after every "
                f"task's run has ended (the longest lasts {longest:g} s): nothing to reduce",
            )
    found = [task_outputs(task) for task in kinds.values()]
    for index, metric in enumerate(plan.sweep.config.metrics):
        problems = [
            path_problem(outputs, metric.path) if metric.path else series_problem(outputs, metric)
            for outputs in found
        ]
        if all(problems):
            given = f"path '{metric.path}'" if metric.path else f"series '{metric.series}'"
            raise located(
                plan.sweep.path,
                metric_line(plan.sweep, index),
                f"metrics: entry {index + 1}: {given}: {problems[0]}",
            )
