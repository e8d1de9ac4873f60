"""`hlcmp report`: run bundled scenarios and write one offline page linking their runs."""

from __future__ import annotations

import dataclasses as dc
import os
import time
from pathlib import Path
from typing import Callable, Sequence

from hlcmp_drake.config.loading import load_scenario, resolve_variant_path
from hlcmp_drake.config.scenario import ArmTask
from hlcmp_drake.config.variants import changed_keys
from hlcmp_drake.experiments import experiment_of
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.outputs import MANIFEST, WRITTEN, replacing_outputs, write_text
from hlcmp_drake.io.paths import bundled_scenarios
from hlcmp_drake.present.progress import SILENT, Progress
from hlcmp_drake.present.report import ReportSection, report_page
from hlcmp_drake.run.probe import run_probe
from hlcmp_drake.run.runner import experiment_worlds, run_one, write_scenario
from hlcmp_drake.run.sweep.engines import ENGINES, run_in_processes, run_on_ray
from hlcmp_drake.run.sweep.tasks import quiet_drake, run_in_temporary_folder, store_files
from hlcmp_drake.worlds.build import diagram_factory

# The report's page, in its folder beside the scenarios' folders.
PAGE = "index.html"


@dc.dataclass
class ReportResult:
    """The page written, each scenario's section, each run folder's metrics.json content
    ({folder: metrics}, in page order) and the total wall time [s]."""

    page: Path
    sections: list
    runs: dict
    wall_s: float

    @property
    def statuses(self) -> list:
        """Each run folder's status, "ok" or "unstable", in page order."""
        return [metrics["status"] for metrics in self.runs.values()]

    @property
    def all_ok(self) -> bool:
        """Whether every scenario's runs ended "ok"."""
        return all(status == "ok" for status in self.statuses)


def report_folders(out_dir: str | Path, scenarios: list[str] | None = None) -> dict[str, Path]:
    """Each scenario of a report and the folder its runs go in, out_dir/<scenario name>,
    every scenario loaded (and so checked) first.

    Parameters
    ----------
    out_dir : str or Path
    scenarios : list of str, optional
        Bundled scenario names or scenario .yaml paths, in page order (default: every
        bundled scenario, in the order of the paper's sections).

    Returns
    -------
    dict of str to Path
        {the scenario as given: its folder}, in page order.

    Raises
    ------
    InputError
        A scenario that does not load (its file and line; a name that is no plain folder
        name among its problems), one given twice, or two with the same name (they would
        share a folder), or one named as a file the report writes in out_dir (its page
        index.html, the folder's manifest).
    """
    if scenarios is None:
        scenarios = sorted(
            bundled_scenarios(), key=lambda n: experiment_of(load_scenario(n)[0]).paper_section
        )
    folders: dict[str, Path] = {}
    given: dict[str, str] = {}
    for entry in scenarios:
        # with what its experiment needs: one that its experiment cannot judge stops here
        scenario, path = load_scenario(entry, experiments=experiment_worlds())
        experiment_of(scenario, path)
        name = scenario.name
        if name in (PAGE, MANIFEST):
            raise InputError(
                f"--scenarios {entry}: its name '{name}' is a file the report writes in "
                f"{out_dir}, where the scenario's folder would go"
            )
        if name in given:
            twice = "is given twice" if given[name] == entry else f"has the name of {given[name]}"
            raise InputError(
                f"--scenarios {entry}: {twice} ('{name}'); each scenario's runs go in "
                f"{Path(out_dir) / name}"
            )
        given[name] = entry
        folders[entry] = Path(out_dir) / name
    return folders


@dc.dataclass(frozen=True)
class _ReportTask:
    """One piece of a report's work: one controller's run of a scenario (under a variant,
    when one is named), or the scenario world's probe."""

    entry: str
    run_dir: str
    probe: bool
    variant: str | None = None
    controller: str | None = None

    @property
    def what(self) -> str:
        """The piece in a progress line."""
        if self.probe:
            return f"{self.entry}'s probe"
        return f"{self.entry}{f' ({self.variant})' if self.variant else ''} {self.controller}"


def _report_work(entry: str, folder: Path, variants: Sequence[str]) -> list[_ReportTask]:
    """A scenario's runs, one task per controller, then its world's probe (the world alone,
    no controller) where the scenario has one, then an arm scenario's runs under each
    variant (each loaded, and so checked, here), in out_dir/<name>_<variant>."""
    scenario, _ = load_scenario(entry)
    work = [
        _ReportTask(entry, str(folder), probe=False, controller=label)
        for label in scenario.controllers
    ]
    if scenario.probe.push_m:
        work.append(_ReportTask(entry, str(folder / "probe"), probe=True))
    if isinstance(scenario.task, ArmTask):
        for variant in variants:
            varied = load_scenario(entry, experiments=experiment_worlds(), variant=variant)[0]
            work += [
                _ReportTask(entry, str(folder.parent / varied.name), False, variant, label)
                for label in varied.controllers
            ]
    return work


def _refuse_shared_folders(work: list[_ReportTask]) -> None:
    """Refuse two scenarios' runs (or a scenario's and a variant's) that would go in one
    folder, each over the other's files: e.g. a scenario named insertion_real_arm beside
    insertion under --variants real_arm, or a variant given as a name and as its file.

    Raises
    ------
    InputError
        "--variants ...: the runs of A and of B would both go in FOLDER".
    """
    owners: dict[str, _ReportTask] = {}
    for task in work:
        other = owners.setdefault(task.run_dir, task)
        if (other.entry, other.variant) != (task.entry, task.variant):
            raise InputError(
                f"--variants {task.variant or other.variant}: the runs of {_runs_of(other)} "
                f"and of {_runs_of(task)} would both go in {task.run_dir}"
            )


def _runs_of(task: _ReportTask) -> str:
    """The scenario (and variant) of a task, in a message."""
    return task.entry + (f" under {task.variant}" if task.variant else "")


def _do(task: _ReportTask, reporter: Progress = SILENT) -> dict:
    """Do one piece of a report in this process: a probe writes its folder; a run writes
    nothing and returns its RunResult (`run`), which the report's own process evaluates
    and writes with the scenario's other runs. Also its wall time and the files written."""
    quiet_drake()
    start, first = time.perf_counter(), len(WRITTEN)
    run = None
    if task.probe:
        run_probe(task.entry, task.run_dir)
    else:
        scenario = load_scenario(task.entry, variant=task.variant)[0]
        run = run_one(diagram_factory(scenario), scenario, task.controller, reporter=reporter)
    return {
        "run": run,
        "wall_s": time.perf_counter() - start,
        "written": [str(path) for path in WRITTEN[first:]],
    }


def _do_returning_files(task: _ReportTask) -> tuple[dict, dict]:
    """Do one piece of a report in a temporary folder (a Ray worker's) and return what
    `_do` returns and the folder's files, by path relative to it."""
    return run_in_temporary_folder(_do, task)


def run_report(
    out_dir: str | Path,
    scenarios: list[str] | None = None,
    reporter: Progress = SILENT,
    *,
    jobs: int | None = None,
    variants: Sequence[str] = (),
    engine: str = "local",
) -> ReportResult:
    """Run each scenario into out_dir/<its name> (its probe, if it has one, into
    out_dir/<its name>/probe; an arm scenario under each variant into
    out_dir/<its name>_<variant>) and write out_dir/index.html, a page that works offline.

    Each controller's run and each probe is a task of a sweep engine, `jobs` at a time:
    the local one (`run_in_processes`; with one job they run one after the other in this
    process) or Ray (`run_on_ray`: each task in a temporary folder of its worker, a
    probe's files written here). A run task returns its RunResult; as soon as a
    scenario's last run is in, this process evaluates the runs and writes the scenario's
    folder (`write_scenario`) while the other tasks go on, so that one long scenario
    does not hold a process on its own. The simulations do not depend on which process
    runs them: the runs' files are the same either way, and so is the page but for each
    section's wall time (the sum of its tasks').

    Parameters
    ----------
    out_dir : str or Path
    scenarios : list of str, optional
        Bundled scenario names or scenario .yaml paths (your own), in page order (default:
        every bundled scenario, in the order of the paper's sections). All are loaded and
        checked before the first runs (`report_folders`).
    reporter : Progress, optional
    jobs : int, optional
        Processes (Ray: tasks) at a time, >= 1; default one per CPU (at most one per task).
    variants : sequence of str
        The variants each arm scenario also runs under, shown beside its perfect robot
        (bundled names, e.g. "real_arm", or .yaml paths); default none (each runs the
        arm scenarios again).
    engine : str
        "local" or "ray" (needs Ray: pip install -e '.[ray]').
    """
    out_dir = Path(out_dir)
    folders = report_folders(out_dir, scenarios)
    for variant in variants:
        resolve_variant_path(variant)  # a name or file that is no variant, before any run
        if list(variants).count(variant) > 1:
            raise InputError(f"--variants {variant}: is given twice")
    work = [
        task for entry, folder in folders.items() for task in _report_work(entry, folder, variants)
    ]
    _refuse_shared_folders(work)
    if variants and not any(task.variant for task in work):  # only arm scenarios take them
        raise InputError(
            f"--variants {' '.join(variants)}: only arm scenarios run under a variant, and "
            f"none of {', '.join(folders)} is one"
        )
    if jobs is not None and jobs < 1:
        raise InputError(f"--jobs: must be at least 1, got {jobs}")
    if engine not in ENGINES:
        raise InputError(f"--engine: one of {', '.join(ENGINES)}, got {engine!r}")
    jobs = max(1, min(jobs or os.cpu_count() or 1, len(work)))
    start = time.perf_counter()
    with replacing_outputs(out_dir):  # a scenario left out this time leaves no old folder
        written = _ScenarioWriter(work, reporter)
        _run_work(work, jobs, reporter, engine, written.take)
        sections, runs = [], {}
        for entry, folder in folders.items():
            pieces = [task for task in work if task.entry == entry]
            probe = next((Path(task.run_dir) for task in pieces if task.probe), None)
            scenario = load_scenario(entry)[0]
            varied = {task.variant: Path(task.run_dir) for task in pieces if task.variant}
            sections.append(
                ReportSection(
                    folder.name,
                    folder,
                    sum(written.wall_s[task] for task in pieces),
                    experiment_of(scenario),
                    probe,
                    varied,
                    {
                        variant: changed_keys(scenario, load_scenario(entry, variant=variant)[0])
                        for variant in varied
                    },
                )
            )
            for run_dir in dict.fromkeys(task.run_dir for task in pieces if not task.probe):
                runs[Path(run_dir)] = written.metrics[run_dir]
        page = write_text(out_dir / PAGE, report_page(out_dir, sections))
    return ReportResult(page, sections, runs, time.perf_counter() - start)


class _ScenarioWriter:
    """Collects a report's finished pieces and, as soon as a scenario's (or a variant's)
    last run is in, evaluates and writes its folder in this process (`write_scenario`),
    while the other pieces still run.

    Parameters
    ----------
    work : list of _ReportTask
    reporter : Progress
    """

    def __init__(self, work: list[_ReportTask], reporter: Progress):
        self._waiting: dict[str, list[_ReportTask]] = {}
        for task in work:
            if not task.probe:
                self._waiting.setdefault(task.run_dir, []).append(task)
        self._runs: dict[_ReportTask, object] = {}
        self._reporter = reporter
        self.wall_s: dict[_ReportTask, float] = {}
        self.metrics: dict[str, dict] = {}  # by run folder

    def take(self, task: _ReportTask, result: dict) -> None:
        """One finished piece: keep its run; write its folder when it was the last."""
        self.wall_s[task] = result["wall_s"]
        if task.probe:
            return
        self._runs[task] = result["run"]
        tasks = self._waiting[task.run_dir]
        if any(piece not in self._runs for piece in tasks):
            return
        scenario = load_scenario(task.entry, variant=task.variant)[0]
        start = time.perf_counter()
        written = write_scenario(
            scenario,
            {piece.controller: self._runs.pop(piece) for piece in tasks},
            out_dir=task.run_dir,
            record_scenario=True,  # as `hlcmp run` writes it: DIR/scenario.yaml reruns one
        )
        self.metrics[task.run_dir] = written.metrics
        self._reporter.say(
            f"{Path(task.run_dir).name}: evaluated and written in "
            f"{time.perf_counter() - start:.0f} s"
        )


def _run_work(
    work: list[_ReportTask],
    jobs: int,
    reporter: Progress,
    engine: str,
    take: Callable[[_ReportTask, dict], None],
) -> None:
    """Do each piece, handing `take` its result as it finishes: one after the other here
    (local, one job), in `jobs` processes (local) or as Ray tasks."""
    if engine == "local" and jobs == 1:
        for task in work:
            reporter.say(f"running {task.what} ...")
            take(task, _do(task, reporter))
        return
    where = f"{jobs} processes" if engine == "local" else f"Ray tasks, {jobs} at a time"
    reporter.say(f"running {len(work)} pieces in {where} ...")
    failures = []

    def on_done(task, result, error):
        if error is not None:
            failures.append(f"{task.what}: {error}")
            return
        if engine == "local":
            WRITTEN.extend(Path(path) for path in result["written"])
        else:
            result, files = result
            if task.probe:
                store_files(task.run_dir, files)
        reporter.say(f"{task.what}: done in {result['wall_s']:.0f} s")
        if not failures:
            take(task, result)

    if engine == "local":
        run_in_processes(_do, work, jobs, on_done)
    else:
        run_on_ray(_do_returning_files, work, jobs, on_done)
    if failures:
        raise RuntimeError("the report could not run " + "; ".join(failures))
