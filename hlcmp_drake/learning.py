"""Table I as a user lives it: learn a skill from one's own demonstration over repeated
trials, save it, and reproduce it later (with or without further adaptation).

Each trial is one reproduction of the demonstration in the scenario's world by the
scenario's `hlcmp` controller, starting from the theta the previous trial ended with.
"""

import dataclasses as dc
import time

import numpy as np

from hlcmp_drake.builders import diagram_factory
from hlcmp_drake.errors import InputError
from hlcmp_drake.runner import report_run
from hlcmp_drake.scenario import BasisConfig, DemonstrationConfig, HlcmpConfig
from hlcmp_drake.simulate import simulate
from hlcmp_drake.skill import Skill


def learning_scenario(scenario, demo_path=None, skill: Skill | None = None, freeze=False):
    """The scenario with only its Hl-CMP controller (learning rates 0 with `freeze`),
    reading `demo_path` as its demonstration, and with a skill's phase basis."""
    if not isinstance(scenario.reference, DemonstrationConfig):
        raise InputError(f"scenario '{scenario.name}' does not follow a demonstration; learning and "
                         "reproducing skills needs one that does, such as insertion or cutting")
    config = scenario.controllers.get("hlcmp")
    if not isinstance(config, HlcmpConfig):
        raise InputError(f"scenario '{scenario.name}' has no Hl-CMP controller named 'hlcmp' to learn with")
    if freeze:
        zeros = [0.0] * scenario.n_axes
        config = dc.replace(config, q_k=zeros, q_d=zeros, q_v=zeros)
    reference = scenario.reference
    if demo_path is not None:
        reference = dc.replace(reference, file=str(demo_path))
    basis = scenario.basis
    if skill is not None:
        check_skill_fits(skill, scenario)
        settings = skill.dmp.settings
        basis = BasisConfig(n_basis=settings.n_basis, alpha_s=settings.alpha_s)
        if demo_path is not None:
            reference = dc.replace(reference, alpha=settings.alpha)
    return dc.replace(scenario, controllers={"hlcmp": config}, reference=reference, basis=basis)


def check_skill_fits(skill: Skill, scenario):
    axes = ("x", "y", "z")[: scenario.n_axes]
    if skill.dmp.axis_names != axes:
        raise InputError(f"the skill's axes ({','.join(skill.dmp.axis_names)}) do not match the "
                         f"scenario '{scenario.name}', which controls {','.join(axes)}")


def effort(run):
    """Mean |u + v| over the run, summed over the axes: the size of the learned part of
    the command (Eq. 3), the 'effort' that human motor learning reduces."""
    return float(np.sum(np.mean(np.abs(run.series["u"] + run.series["v"]), axis=0)))


def run_trials(scenario, dmp, trials, theta0=None, progress=None):
    """`trials` reproductions of `dmp`, each starting from the theta the previous one
    ended with (the first from `theta0`, or the scenario's initial weights). Returns the
    RunResults; stops after an unstable trial."""
    build = diagram_factory(scenario, dmp)
    runs = []
    for k in range(trials):
        start = time.perf_counter()
        run = simulate(build("hlcmp", theta0), scenario, f"trial_{k + 1}",
                       progress.step if progress else None)
        if progress:
            report_run(progress, run, time.perf_counter() - start)
        runs.append(run)
        if run.status != "ok":
            break
        theta0 = run.theta
    return runs



def trial_metrics(runs, scenario):
    """Per trial: position error, mean force and smoothness per axis, and effort."""
    from hlcmp_drake.experiments import EXPERIMENTS

    experiment = EXPERIMENTS[scenario.experiment]
    rows = []
    for k, run in enumerate(runs, start=1):
        m = experiment.controller_metrics(run, scenario)
        rows.append({"trial": k, "status": run.status,
                     "mean_abs_position_error_m": m["mean_abs_position_error_m"],
                     "mean_abs_force_N": m["mean_abs_force_N"],
                     "force_smoothness_N": m["force_smoothness_N"], "effort_N": effort(run)})
    return rows


def improvement(rows):
    """Whether the last trial beats the first, per measure (None with a single trial)."""
    if len(rows) < 2:
        return None
    first, last = rows[0], rows[-1]

    def total(row, key):
        return sum(row[key].values())

    return {
        "position_error": total(last, "mean_abs_position_error_m") < total(first, "mean_abs_position_error_m"),
        "mean_force": total(last, "mean_abs_force_N") < total(first, "mean_abs_force_N"),
        "smoothness_z": last["force_smoothness_N"]["z"] < first["force_smoothness_N"]["z"],
        "effort": last["effort_N"] < first["effort_N"],
    }


def trials_figure(rows):
    from hlcmp_drake.plots import new_figure

    fig, axes = new_figure(1, 4, size=(15, 3.6))
    trials = [row["trial"] for row in rows]
    panels = [("mean |e| (x+y+z) [mm]", lambda r: 1000 * sum(r["mean_abs_position_error_m"].values())),
              ("mean |f| (x+y+z) [N]", lambda r: sum(r["mean_abs_force_N"].values())),
              ("smoothness z [N]", lambda r: r["force_smoothness_N"]["z"]),
              ("effort mean |u + v| [N]", lambda r: r["effort_N"])]
    for axis, (label, value) in zip(axes, panels):
        axis.plot(trials, [value(r) for r in rows], "o-")
        axis.set_xlabel("trial")
        axis.set_title(label)
        axis.set_xticks(trials)
        axis.grid(alpha=0.3)
    fig.suptitle("Learning over repeated trials")
    return fig


def trial_outputs(scenario, dmp, trials, theta0, progress, demo=None, skill_path=None, frozen=False):
    """Run the trials; return (runs by name, metrics.json content, figures)."""
    from hlcmp_drake.experiments import EXPERIMENTS

    runs = run_trials(scenario, dmp, trials, theta0, progress)
    rows = trial_metrics(runs, scenario)
    unstable = [run for run in runs if run.status != "ok"]
    metrics = {"scenario": scenario.name, "status": "unstable" if unstable else "ok",
               "demonstration": None if demo is None else str(demo),
               "started_from_skill": None if skill_path is None else str(skill_path),
               "adaptation": "frozen" if frozen else "on",
               "trials": rows, "improves_over_trials": improvement(rows)}
    if unstable:
        run = unstable[0]
        metrics["instability"] = {run.controller: {"reason": run.reason, "time_s": run.stop_time}}
    by_name = {run.controller: run for run in runs}
    figures = {}
    if not unstable:
        figures = EXPERIMENTS[scenario.experiment].figures({"hlcmp": runs[-1]}, scenario)
        figures["trials.png"] = trials_figure(rows)
    return by_name, metrics, figures
