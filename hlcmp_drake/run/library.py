"""Skill libraries (`hlcmp library`): at every combination of a library file's task
parameters, a skill learned as `hlcmp learn` learns it (its trials, the first from
theta = 0), on the sweep's engines (a local process pool, or Ray), resumable; and
DIR/library.json, the index that `hlcmp generalize` reads.

DIR/skills/ID/ holds what `hlcmp learn` writes (skill.npz, metrics.json, timeseries.npz,
figures/, recording.html), after the skill's scenario.yaml (first) and before its
library_task.json (last). A skill is finished when its folder holds library_task.json for
the same number of trials and the same learner beside a scenario.yaml equal to the one
planned (and the same contents of the files it names: inputs.sha256, as a sweep's task),
and its metrics.json and (unless it went unstable) skill.npz still there; anything else is
learned (again). library.json is rewritten after every finished skill, so an
interrupted library loses none, and the same command again learns only what is missing.

library.json::

    {"format_version": 1, "scenario": NAME, "scenario_path": PATH, "library_file": PATH,
     "set": {KEY: YAML}, "trials": K, "demo_force": BOOL, "controller": LABEL,
     "parameters": [KEY, ...],
     "skills": [{"id": ID, "query": {KEY: VALUE}, "skill": "skills/ID/skill.npz",
                 "metrics": {the last trial's row of the skill's metrics.json}}],
     "not_learned": [{"id": ID, "query": {...}, "status": "unstable|error|pending", ...}]}
"""

from __future__ import annotations

import dataclasses as dc
import json
import os
import time
from pathlib import Path

from hlcmp_drake.config.library import (
    LibrarySpec,
    LibraryTask,
    load_library_spec,
    plan_library_tasks,
)
from hlcmp_drake.config.loading import line_of, load_scenario, load_scenario_text
from hlcmp_drake.config.sweep import INPUTS_FILE
from hlcmp_drake.io import outputs
from hlcmp_drake.io.errors import InputError, located
from hlcmp_drake.io.skill import load_skill
from hlcmp_drake.present.progress import SILENT, Progress
from hlcmp_drake.run.learning import learn, learning_scenario
from hlcmp_drake.run.sweep.engines import (
    _run_ray,
    _terminate_is_interrupt,
    check_engine,
    cluster_joined,
    run_in_processes,
)
from hlcmp_drake.run.sweep.tasks import ran_with, run_in_temporary_folder
from hlcmp_drake.worlds.controllers import learners

LIBRARY_FILE = "library.json"
LIBRARY_FORMAT_VERSION = 1
TASK_RECORD = "library_task.json"  # a skill's last file: it is finished


def run_library_task(task: LibraryTask) -> dict:
    """Learn one skill of a library in this process: its scenario.yaml first, then what
    `hlcmp learn` writes, then library_task.json (id, query, trials, status, wall time).

    Parameters
    ----------
    task : LibraryTask

    Returns
    -------
    dict
        The library_task.json content.
    """
    run_dir = Path(task.run_dir)
    (run_dir / TASK_RECORD).unlink(missing_ok=True)  # an old record never passes for this one
    scenario_file = outputs.write_text(run_dir / "scenario.yaml", task.scenario_yaml)
    outputs.write_text(run_dir / INPUTS_FILE, task.inputs_digest + "\n")
    start = time.perf_counter()
    # The overrides again over the dumped scenario (which holds them already): `learn`
    # sets a trial's duration from the skill unless they set duration_s.
    result = learn(
        scenario_file,
        run_dir,
        trials=task.trials,
        demo_force=task.demo_force,
        controller=task.controller or None,
        overrides=task.overrides,
    )
    info = {
        "id": task.id,
        "query": task.query,
        "trials": task.trials,
        "demo_force": task.demo_force,
        "controller": task.controller,
        "overrides": task.overrides,
        "status": result.metrics["status"],
        "wall_s": round(time.perf_counter() - start, 3),
    }
    outputs.write_json(run_dir / TASK_RECORD, info)
    return info


def run_library_task_returning_files(task: LibraryTask) -> tuple[dict, dict]:
    """`run_library_task` in a temporary folder, returning its files (for a Ray node that
    does not share the library's file system).

    Parameters
    ----------
    task : LibraryTask

    Returns
    -------
    (dict, dict of str to bytes)
        The library_task.json content, and every file by relative path.
    """
    return run_in_temporary_folder(run_library_task, task)


def skill_state(task: LibraryTask) -> str:
    """ "done" (learned with the same scenario, trials and learner, and its files there),
    "stale" (with others, or a file of it lost or damaged: learned again) or "pending".

    Parameters
    ----------
    task : LibraryTask
    """
    run_dir = Path(task.run_dir)
    try:
        record = json.loads((run_dir / TASK_RECORD).read_text())
    except (OSError, ValueError):
        return "pending"
    # What library.json takes from a finished skill; only a stable one saved a skill.
    needed = ["metrics.json"] + (["skill.npz"] if record.get("status") == "ok" else [])
    if (
        any(not _readable(run_dir / name) for name in needed)
        or not ran_with(run_dir, task.scenario_yaml, task.inputs_digest)
        or record.get("trials") != task.trials
        or record.get("demo_force", False) != task.demo_force
    ):
        return "stale"
    return "done" if _learned_by(record, task) == task.controller else "stale"


def _readable(path: Path) -> bool:
    """Whether a skill's metrics.json or skill.npz is there and reads (`generalize` reads
    both)."""
    try:
        if path.suffix == ".npz":
            load_skill(path)
        else:
            json.loads(path.read_text())
    except (OSError, ValueError, InputError):
        return False
    return True


def _learned_by(record: dict, task: LibraryTask) -> str | None:
    """The learner a skill's record names; for a record from before it named one, the
    learner `learn` took then: the first of its scenario.yaml, whose controllers a YAML
    dump sorts by label."""
    if "controller" in record:
        return record["controller"]
    dumped = load_scenario_text(task.scenario_yaml, task.scenario_path)
    return next(iter(learners(dumped)), None)


@dc.dataclass
class LibraryResult:
    """What `build_library` returns.

    Attributes
    ----------
    record : dict
        The library.json content.
    out_dir : Path
    already_done : int
        Skills that were learned before this call (kept as they were).
    ran : list of str
        The ids learned by this call (failed ones included).
    failed : dict of str to str
        Id -> error, for skills whose learning raised (a re-run retries them).
    unstable : list of str
        Ids whose learning went unstable (no skill saved; metrics.json says why).
    wall_s : float
    """

    record: dict
    out_dir: Path
    already_done: int
    ran: list
    failed: dict
    unstable: list
    wall_s: float


def library_learner(spec: LibrarySpec, task: LibraryTask) -> str:
    """The label of the controller that learns the library's skills: the file's
    `controller`, else the scenario's first learner in its file's order (as `hlcmp learn`
    takes it). Refuses, naming the library file's line, a scenario that `hlcmp learn`
    cannot learn in (no demonstration, no learning controller) or a `controller` that is
    not one of its learners.

    Parameters
    ----------
    spec : LibrarySpec
    task : LibraryTask
        Any of the library's skills (they share the scenario and its controllers).

    Returns
    -------
    str

    Raises
    ------
    InputError
    """
    scenario, _ = load_scenario(spec.scenario_path, task.overrides)
    try:
        learning_scenario(scenario)
    except InputError as error:
        raise located(spec.path, line_of(spec.text, "scenario"), f"scenario: {error}") from None
    labels, wanted = learners(scenario), spec.config.controller
    if wanted and wanted not in labels:
        raise located(
            spec.path,
            line_of(spec.text, "controller"),
            f"controller: '{wanted}' is not a learning controller of scenario "
            f"'{scenario.name}' (its learners: {', '.join(labels)})",
        )
    return wanted or labels[0]


def library_tasks(spec: LibrarySpec, out_dir: str | Path) -> list[LibraryTask]:
    """Every skill of a library (`plan_library_tasks`), each with its learner
    (`library_learner`).

    Parameters
    ----------
    spec : LibrarySpec
    out_dir : str or Path
        The library's folder.

    Returns
    -------
    list of LibraryTask

    Raises
    ------
    InputError
        As `plan_library_tasks` and `library_learner`.
    """
    tasks = plan_library_tasks(spec, out_dir)
    controller = library_learner(spec, tasks[0])
    return [dc.replace(task, controller=controller) for task in tasks]


def build_library(
    name_or_path: str | Path,
    out_dir: str | Path,
    engine: str = "local",
    workers: int | None = None,
    address: str | None = None,
    reporter: Progress = SILENT,
) -> LibraryResult:
    """Learn every skill of a library file that is not learned yet, and write library.json.

    Parameters
    ----------
    name_or_path : str or Path
        A bundled library (diagrams/libraries/NAME.yaml) or a library file.
    out_dir : str or Path
        The library's folder.
    engine : str
        "local" (a process pool) or "ray".
    workers : int, optional
        Skills learned at once. Local default: os.cpu_count(); Ray: as many as it schedules.
    address : str, optional
        Ray only: the cluster to join.
    reporter : Progress, optional
        One line per learned skill.

    Returns
    -------
    LibraryResult

    Raises
    ------
    InputError
        Before anything is learned: a bad library file or override (file:line), a scenario
        that cannot be learned in, an unknown engine, Ray not installed.
    KeyboardInterrupt
        On Ctrl-C or SIGTERM, after the workers are stopped; every learned skill is kept.
    """
    check_engine(engine, workers, address)  # before anything is written
    with cluster_joined(engine, address):  # no cluster at the address: nothing run or written
        start = time.perf_counter()
        spec = load_library_spec(name_or_path)
        out_dir = Path(out_dir)
        tasks = library_tasks(spec, out_dir)
        states = {task.id: skill_state(task) for task in tasks}
        errors: dict = {}
        pending = [task for task in tasks if states[task.id] != "done"]
        already_done = len(tasks) - len(pending)
        outputs.write_json(out_dir / LIBRARY_FILE, library_record(spec, tasks, errors))
        ran: list = []

        def on_done(task, info, error):
            ran.append(task.id)
            if error is not None:
                errors[task.id] = error
            outputs.write_json(out_dir / LIBRARY_FILE, library_record(spec, tasks, errors))
            status = "error" if error else info["status"]
            reporter.say(
                f"[{already_done + len(ran)}/{len(tasks)}] {task.id}: {status}"
                + (f" ({error})" if error else f", {info['wall_s']:.1f} s")
            )

        if pending:
            count = min(workers or os.cpu_count() or 1, len(pending))
            reporter.say(
                f"library {spec.path.stem}: {len(pending)} of {len(tasks)} skills to learn "
                f"({already_done} already learned) on the {engine} engine"
            )
            with _terminate_is_interrupt():
                if engine == "local":
                    run_in_processes(run_library_task, pending, count, on_done)
                else:
                    _run_ray(pending, workers, address, on_done, run_library_task_returning_files)
        record = library_record(spec, tasks, errors)
        outputs.write_json(out_dir / LIBRARY_FILE, record)
        unstable = [e["id"] for e in record["not_learned"] if e["status"] == "unstable"]
        return LibraryResult(
            record, out_dir, already_done, ran, errors, unstable, time.perf_counter() - start
        )


def library_record(spec: LibrarySpec, tasks: list, errors: dict) -> dict:
    """library.json's content from what the skills' folders hold now.

    Parameters
    ----------
    spec : LibrarySpec
    tasks : list of LibraryTask
    errors : dict of str to str
        Id -> the error of a skill whose learning raised in this call.

    Returns
    -------
    dict
        See the module's docstring.
    """
    scenario, _ = load_scenario(spec.scenario_path, tasks[0].overrides)
    skills, not_learned = [], []
    for task in tasks:
        entry = {"id": task.id, "query": task.query}
        state = skill_state(task)
        if task.id in errors:
            not_learned.append({**entry, "status": "error", "error": errors[task.id]})
            continue
        if state != "done":
            not_learned.append({**entry, "status": "pending"})
            continue
        run_dir = Path(task.run_dir)
        metrics = json.loads((run_dir / "metrics.json").read_text())
        if metrics["status"] != "ok":
            reason = metrics.get("instability", {})
            not_learned.append({**entry, "status": metrics["status"], "instability": reason})
            continue
        skills.append(
            {
                **entry,
                "skill": (run_dir / "skill.npz").relative_to(run_dir.parent.parent).as_posix(),
                "metrics": metrics["trials"][-1],
            }
        )
    return {
        "format_version": LIBRARY_FORMAT_VERSION,
        "scenario": scenario.name,
        "scenario_path": str(spec.scenario_path.resolve()),
        "library_file": str(spec.path.resolve()),
        "set": dict(spec.config.set),
        "trials": spec.config.trials,
        "demo_force": spec.config.demo_force,
        "controller": tasks[0].controller,
        "parameters": list(spec.parameters),
        "skills": skills,
        "not_learned": not_learned,
    }
