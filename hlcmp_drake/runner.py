"""Run every controller of a scenario and write metrics, time series and figures."""

import sys
import time
from pathlib import Path

import numpy as np

from hlcmp_drake import outputs
from hlcmp_drake.builders import diagram_factory
from hlcmp_drake.experiments import EXPERIMENTS
from hlcmp_drake.recording import record_runs
from hlcmp_drake.scenario import load_scenario, use_drake_models_iiwa
from hlcmp_drake.progress import Progress
from hlcmp_drake.simulate import simulate


def _experiment(scenario):
    """The evaluation module the scenario names."""
    return EXPERIMENTS[scenario.experiment]


def run_controllers(scenario, progress: Progress | None = None, build=None):
    """Build and simulate one diagram per controller; returns {name: RunResult}."""
    build = build or diagram_factory(scenario)
    runs = {}
    for name in scenario.controllers:
        start = time.perf_counter()
        runs[name] = simulate(build(name), scenario, name, progress.step if progress else None)
        if progress:
            report_run(progress, runs[name], time.perf_counter() - start)
    return runs


def report_run(progress, run, wall_s):
    progress.say(f"{run.controller}: {run.t[-1]:.2f} s simulated in {wall_s:.1f} s "
                 f"({run.t[-1] / wall_s:.2f}x real time), {run.status}"
                 + (f": {run.reason} at t = {run.stop_time:.3f} s" if run.status != "ok" else ""))


def timeseries_arrays(runs):
    """The timeseries.npz contract: `t`, and `CTRL/NAME` arrays (T x M), NaN-padded where
    a run stopped early."""
    longest = max(runs.values(), key=lambda r: len(r.t))
    arrays = {"t": longest.t}
    for name, run in runs.items():
        for key, values in run.series.items():
            padded = np.full((len(longest.t), values.shape[1]), np.nan)
            padded[: len(values)] = values
            arrays[f"{name}/{key}"] = padded
    return arrays


def evaluate(runs, scenario):
    experiment = _experiment(scenario)
    unstable = {n: r for n, r in runs.items() if r.status != "ok"}
    metrics = {
        "scenario": scenario.name,
        "status": "unstable" if unstable else "ok",
        "controllers": {n: experiment.controller_metrics(r, scenario) for n, r in runs.items()},
    }
    if unstable:
        metrics["instability"] = {n: {"reason": r.reason, "time_s": r.stop_time}
                                  for n, r in unstable.items()}
        metrics["claims"] = {}
    else:
        metrics["claims"] = experiment.claims(metrics["controllers"], scenario, runs)
    return metrics


def write_results(out_dir, scenario, runs, metrics, figures, diagram=None):
    """Everything a run leaves in out_dir, each file written atomically; metrics.json comes
    last, so a metrics.json next to older files never describes them."""
    outputs.write_npz(out_dir / "timeseries.npz", timeseries_arrays(runs))
    for file_name, figure in figures.items():
        outputs.save_figure(out_dir / "figures" / file_name, figure)
    outputs.write_text(out_dir / "recording.html", record_runs(scenario, runs))
    if diagram is not None:
        outputs.write_diagram_graph(out_dir, diagram)
    outputs.write_json(out_dir / "metrics.json", metrics)


def run_scenario(name_or_path, out_dir=None, progress=None, drake_models_iiwa=False):
    """Load, run, evaluate and write one scenario. Returns (metrics, out_dir, table text).
    drake_models_iiwa: use Drake's official iiwa14 model instead of ours (needs internet)."""
    scenario, _ = load_scenario(name_or_path)
    if drake_models_iiwa:
        scenario = use_drake_models_iiwa(scenario)
    out_dir = Path(out_dir or Path("out") / scenario.name)
    build = diagram_factory(scenario)
    runs = run_controllers(scenario, progress, build)
    metrics = evaluate(runs, scenario)
    experiment = _experiment(scenario)
    figures = experiment.figures(runs, scenario) if metrics["status"] == "ok" else {}
    write_results(out_dir, scenario, runs, metrics, figures,
                  build(next(iter(scenario.controllers))).diagram)
    return metrics, out_dir, experiment.table(metrics["controllers"])


def print_summary(metrics, out_dir, table, stream=None):
    stream = stream or sys.stdout   # looked up now: it may have been replaced since import
    print(table, file=stream)
    for controller, problem in metrics.get("instability", {}).items():
        print(f"UNSTABLE {controller}: {problem['reason']} at t = {problem['time_s']:.3f} s "
              "(stopped there; its logs up to then are in timeseries.npz)", file=stream)
    for claim, result in metrics.get("claims", {}).items():
        print(f"{claim}: {'reproduced' if result['holds'] else 'NOT reproduced'} -- {result['evidence']}",
              file=stream)
    print(f"status: {metrics['status']}; results in {out_dir}", file=stream)
