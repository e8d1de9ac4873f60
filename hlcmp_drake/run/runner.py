"""Run every controller of a scenario, evaluate the runs, and write metrics, time
series, figures, the recording and the diagram's graph."""

from __future__ import annotations

import copy
import dataclasses as dc
import time
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Sequence

from hlcmp_drake.config.loading import dump_scenario, load_scenario
from hlcmp_drake.config.scenario import DemonstrationConfig, Scenario
from hlcmp_drake.config.validation import ExperimentNeeds
from hlcmp_drake.config.variants import use_drake_models_iiwa
from hlcmp_drake.experiments import EXPERIMENTS, Experiment, experiment_of
from hlcmp_drake.experiments.table import Table
from hlcmp_drake.io import outputs
from hlcmp_drake.io.paths import data_url
from hlcmp_drake.io.runs import RunResult, instability_record, timeseries_arrays
from hlcmp_drake.present.progress import SILENT, Progress
from hlcmp_drake.present.recording import LiveView

if TYPE_CHECKING:
    from pydrake.geometry import Meshcat
from hlcmp_drake.present.recording import record_runs
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.worlds.build import diagram_factory
from hlcmp_drake.worlds.controllers import learners as learning_controllers

NO_LEARNER = "without a learner"  # the claims' key when a scenario has no Hl-CMP


def experiment_worlds() -> dict[str, ExperimentNeeds]:
    """What `load_scenario` checks a scenario's `experiment` against before a run.

    Returns
    -------
    dict of str to ExperimentNeeds
        Each registered experiment's name to the task class its world needs and the frames
        of the models its metrics read, and whether it judges its task by a puncture's tear.
    """
    return {
        name: ExperimentNeeds(experiment.world, experiment.model_frames, experiment.needs_puncture)
        for name, experiment in EXPERIMENTS.items()
    }


def run_one(
    build: Callable,
    scenario: Scenario,
    controller: str,
    *,
    label: str | None = None,
    theta0: tuple | None = None,
    reporter: Progress = SILENT,
    live: LiveView | None = None,
) -> RunResult:
    """Build the diagram of `controller`, simulate it, and report its real-time factor and
    status.

    Parameters
    ----------
    build : callable(label, theta0) -> BuiltDiagram
        From `diagram_factory`.
    scenario : Scenario
    controller : str
        The controller's label.
    label : str, optional
        The RunResult's name (default the controller's label; a trial's name in learning).
    theta0 : tuple of three (M, N) arrays, optional
        A learner's initial weights.
    reporter : Progress, optional
    """
    label = label or controller
    start = time.perf_counter()
    run = simulate(build(controller, theta0), scenario, label, reporter.step, live)
    wall_s = time.perf_counter() - start
    reporter.say(
        f"{run.controller}: {run.t[-1]:.2f} s simulated in {wall_s:.1f} s "
        f"({run.t[-1] / wall_s:.2f}x real time), {run.status}"
        + (f": {run.reason} at t = {run.stop_time:.3f} s" if run.status != "ok" else "")
    )
    return run


def run_controllers(
    scenario: Scenario,
    *,
    reporter: Progress = SILENT,
    build: Callable | None = None,
    live: LiveView | None = None,
) -> dict[str, RunResult]:
    """Build and simulate one diagram per controller.

    Parameters
    ----------
    scenario : Scenario
    reporter : Progress, optional
    build : callable, optional
        A `diagram_factory(scenario)` to reuse (made here when not given).
    live : LiveView, optional
        Draws each run in a live Meshcat while it simulates.

    Returns
    -------
    dict of str to RunResult
        By controller label, in the scenario's order.
    """
    build = build or diagram_factory(scenario)
    return {
        name: run_one(build, scenario, name, reporter=reporter, live=live)
        for name in scenario.controllers
    }


def evaluate(runs: dict[str, RunResult], scenario: Scenario, experiment: Experiment) -> dict:
    """The metrics.json content: status, every controller's metrics, each learner's reading
    of Q (`learners`), and the claims judged for each learner (`claims`: {learner:
    {claim: ...}}; none when a run was unstable: its `instability` says where and why).

    Parameters
    ----------
    runs : dict of str to RunResult
    scenario : Scenario
    experiment : Experiment
        How the runs are evaluated.
    """
    unstable = instability_record(runs.values())
    metrics = {
        "scenario": scenario.name,
        "status": "unstable" if unstable else "ok",
        "controllers": {
            n: experiment.metrics_of(r, scenario.controllers[n], scenario) for n, r in runs.items()
        },
    }
    learners = learning_controllers(scenario)
    metrics["learners"] = {
        name: {"q_units": scenario.controllers[name].q_units} for name in learners
    }
    if unstable:
        metrics["instability"] = unstable
        metrics["claims"] = {}
    else:
        metrics["claims"] = {
            name or NO_LEARNER: experiment.claims(metrics["controllers"], scenario, runs, name)
            for name in learners or [None]
        }
    return metrics


def write_results(
    out_dir: Path,
    scenario: Scenario,
    runs: dict,
    metrics: dict,
    figures: dict,
    diagram: object | None = None,
    scenario_text: str | None = None,
) -> None:
    """Everything a run leaves in out_dir, each file written atomically; metrics.json comes
    last, so a metrics.json next to older files never describes them.

    Parameters
    ----------
    out_dir : Path
    scenario : Scenario
        For the recording.
    runs : dict of str to RunResult
    metrics : dict
        The metrics.json content.
    figures : dict of str to Figure
        Written under figures/.
    diagram : Diagram, optional
        Drawn as diagram.svg (or .dot).
    scenario_text : str, optional
        Written as scenario.yaml.
    """
    if scenario_text is not None:
        outputs.write_text(out_dir / "scenario.yaml", scenario_text)
    outputs.write_npz(out_dir / "timeseries.npz", timeseries_arrays(runs))
    for file_name, figure in figures.items():
        outputs.save_figure(out_dir / "figures" / file_name, figure)
    outputs.write_text(out_dir / "recording.html", record_runs(scenario, runs))
    if diagram is not None:
        outputs.write_diagram_graph(out_dir, diagram)
    outputs.write_json(out_dir / "metrics.json", metrics)


@dc.dataclass
class ScenarioResult:
    """What `run_scenario` returns: the metrics.json content, where the files went, the
    controllers' metrics as a Table, the experiment that evaluated the runs, and the
    scenario as it ran."""

    metrics: dict
    out_dir: Path
    table: Table
    experiment: Experiment
    scenario: Scenario


def run_scenario(
    name_or_path: str | Path,
    out_dir: str | Path | None = None,
    *,
    reporter: Progress = SILENT,
    drake_models_iiwa: bool = False,
    overrides: Sequence[str] = (),
    meshcat: Meshcat | None = None,
    variant: str | None = None,
) -> ScenarioResult:
    """Load, run, evaluate and write one scenario.

    Parameters
    ----------
    name_or_path : str or Path
        A bundled scenario or a YAML file.
    out_dir, reporter, drake_models_iiwa, meshcat
        As for `run_loaded_scenario`.
    overrides : sequence of str
        ``dotted.key=value`` overrides layered over the file (see `load_scenario`).
    variant : str, optional
        A variant layered over the file before the overrides (see `load_scenario`), e.g.
        "real_arm".
    """
    scenario, path = load_scenario(name_or_path, overrides, experiment_worlds(), variant)
    return run_loaded_scenario(
        scenario,
        path,
        out_dir,
        reporter=reporter,
        drake_models_iiwa=drake_models_iiwa,
        meshcat=meshcat,
        record_scenario=True,
    )


def scenario_record(scenario: Scenario) -> str:
    """A run's scenario.yaml: the scenario as it ran (`dump_scenario`, its controllers in
    their order), its demonstration named as `data_url` gives it (a bundled one by its
    package URL, which any installation finds; another by its absolute path).

    Parameters
    ----------
    scenario : Scenario
        As loaded (its demonstration's path resolved).

    Returns
    -------
    str
        A YAML document `hlcmp run` takes.
    """
    recorded = copy.deepcopy(scenario)
    if isinstance(recorded.reference, DemonstrationConfig):
        recorded.reference.file = data_url(recorded.reference.file)
    return dump_scenario(recorded, controllers_in_order=True)


def without_claims(experiment: Experiment) -> Experiment:
    """`experiment` judging no claim: for runs that keep only some of a scenario's
    controllers (a sweep's, a served one), since the claims compare controllers.

    Parameters
    ----------
    experiment : Experiment

    Returns
    -------
    Experiment
        The same metrics, table and figures; its claims are {}.
    """
    return dc.replace(experiment, claims=lambda metrics, scenario, runs=None, learner_name=None: {})


def run_loaded_scenario(
    scenario: Scenario,
    path: str | Path | None = None,
    out_dir: str | Path | None = None,
    *,
    reporter: Progress = SILENT,
    drake_models_iiwa: bool = False,
    claims: bool = True,
    meshcat: Meshcat | None = None,
    record_scenario: bool = False,
) -> ScenarioResult:
    """Run, evaluate and write a scenario that is already loaded (`run_scenario` after
    `load_scenario`; a sweep's worker after `load_scenario_text`).

    Parameters
    ----------
    scenario : Scenario
        As loaded and validated.
    path : str or Path, optional
        Its file, which an error about its `experiment` line names.
    out_dir : str or Path, optional
        Where to write (default out/<scenario name>).
    reporter : Progress, optional
        Receives progress (silent by default).
    drake_models_iiwa : bool
        Use Drake's official iiwa14 model instead of ours (needs internet).
    claims : bool
        Evaluate the experiment's claims (default). A sweep that keeps only some of the
        scenario's controllers turns them off: they compare controllers that are gone;
        metrics.json then holds no claim.
    meshcat : Meshcat, optional
        Also draw each run in this live Meshcat while it simulates (`hlcmp run --meshcat`).
    record_scenario : bool
        Also write scenario.yaml: the scenario as it ran (`hlcmp run`'s; a sweep's or a
        library's task writes its own first, which its resumption compares).

    Returns
    -------
    ScenarioResult
    """
    experiment_of(scenario, path)  # an experiment that does not fit stops before any run
    if drake_models_iiwa:
        scenario = use_drake_models_iiwa(scenario)
    build = diagram_factory(scenario)
    live = LiveView(scenario, meshcat) if meshcat is not None else None
    runs = run_controllers(scenario, reporter=reporter, build=build, live=live)
    return write_scenario(
        scenario,
        runs,
        path,
        out_dir,
        build=build,
        claims=claims,
        record_scenario=record_scenario,
    )


def write_scenario(
    scenario: Scenario,
    runs: dict[str, RunResult],
    path: str | Path | None = None,
    out_dir: str | Path | None = None,
    *,
    build: Callable | None = None,
    claims: bool = True,
    record_scenario: bool = False,
) -> ScenarioResult:
    """Evaluate a scenario's runs and write its results (`write_results`), replacing what
    an earlier run left in out_dir: the second half of `run_loaded_scenario`, for runs
    simulated elsewhere too (`hlcmp report`'s, one task per controller).

    Parameters
    ----------
    scenario : Scenario
        As it ran.
    runs : dict of str to RunResult
        Every controller's run, by label, in the scenario's order.
    path, out_dir, claims, record_scenario
        As for `run_loaded_scenario`.
    build : callable, optional
        The scenario's `diagram_factory`, to draw the diagram's graph (made here when not
        given).

    Returns
    -------
    ScenarioResult
    """
    experiment = experiment_of(scenario, path)
    out_dir = Path(out_dir or Path("out") / scenario.name)
    build = build or diagram_factory(scenario)
    metrics = evaluate(runs, scenario, experiment if claims else without_claims(experiment))
    figures = experiment.figures(runs, scenario) if metrics["status"] == "ok" else {}
    with outputs.replacing_outputs(out_dir):  # a reused folder keeps no older run's files
        write_results(
            out_dir,
            scenario,
            runs,
            metrics,
            figures,
            build(next(iter(scenario.controllers))).diagram,
            scenario_record(scenario) if record_scenario else None,
        )
    return ScenarioResult(
        metrics, out_dir, experiment.table(metrics["controllers"]), experiment, scenario
    )
