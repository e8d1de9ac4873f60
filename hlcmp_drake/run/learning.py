"""Table I as a user lives it: learn a skill from one's own demonstration over repeated
trials, save it, and reproduce it later (with or without further adaptation).

Each trial is one reproduction of the demonstration in the scenario's world by the
scenario's learning controller (its Hl-CMP, found by config kind), starting from the
theta the previous trial ended with.
"""

from __future__ import annotations

import dataclasses as dc
from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.scenario import DemonstrationConfig, Scenario
from hlcmp_drake.core.dmp import Dmp
from hlcmp_drake.experiments import experiment_of
from hlcmp_drake.experiments.claims import learner
from hlcmp_drake.experiments.plots import new_figure
from hlcmp_drake.experiments.table import Table, number
from hlcmp_drake.io import outputs
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.runs import RunResult, instability_record
from hlcmp_drake.io.skill import Skill, save_skill
from hlcmp_drake.present.progress import SILENT, Progress
from hlcmp_drake.run.runner import run_one, write_results
from hlcmp_drake.worlds.arm import fit_demonstration
from hlcmp_drake.worlds.build import diagram_factory
from hlcmp_drake.worlds.controllers import controller_kind


def learning_scenario(
    scenario: Scenario,
    demo_path: str | Path | None = None,
    skill: Skill | None = None,
    freeze: bool = False,
) -> Scenario:
    """The scenario reduced to learning: only its Hl-CMP (learning rates 0 with `freeze`),
    reading `demo_path` as its demonstration, with a skill's DMP settings.

    Parameters
    ----------
    scenario : Scenario
        With a demonstration and an Hl-CMP (found by kind).
    demo_path : str or Path, optional
        The user's demonstration CSV.
    skill : Skill, optional
        Whose DMP settings (basis, alpha, beta) replace the scenario's.
    freeze : bool
        Learning rates Q = 0: the profiles stay as they start.

    Raises
    ------
    InputError
        Without a demonstration or an Hl-CMP, or when the skill's axes do not fit.
    """
    if not isinstance(scenario.reference, DemonstrationConfig):
        raise InputError(
            f"scenario '{scenario.name}' does not follow a demonstration; learning and "
            "reproducing skills needs one that does, such as insertion or cutting"
        )
    name = learner(scenario)
    if name is None:
        raise InputError(
            f"scenario '{scenario.name}' has no learning controller (e.g. !HlcmpConfig) to learn "
            "with"
        )
    config = scenario.controllers[name]
    if freeze:
        frozen = controller_kind(scenario, name).frozen
        assert frozen is not None  # every learner's kind can be frozen
        config = frozen(config)
    reference = scenario.reference
    if demo_path is not None:
        reference = dc.replace(reference, file=str(demo_path))
    settings = scenario.dmp
    if skill is not None:
        check_skill_fits(skill, scenario)
        # The skill's basis and transformation system; the scenario's smoothing for a new demo.
        settings = dc.replace(skill.dmp.settings, smoothing_s=scenario.dmp.smoothing_s)
    return dc.replace(scenario, controllers={name: config}, reference=reference, dmp=settings)


def check_skill_fits(skill: Skill, scenario: Scenario) -> None:
    """Raise InputError when the skill's axes are not the ones the scenario controls.

    Parameters
    ----------
    skill : Skill
    scenario : Scenario
    """
    axes = ("x", "y", "z")[: scenario.n_axes]
    if skill.dmp.axis_names != axes:
        raise InputError(
            f"the skill's axes ({','.join(skill.dmp.axis_names)}) do not match the "
            f"scenario '{scenario.name}', which controls {','.join(axes)}"
        )


def effort(run: RunResult) -> float:
    """Mean |u + v| [N] over the run, summed over the axes: the size of the learned part
    of the command (Eq. 3), the 'effort' that human motor learning reduces.

    Parameters
    ----------
    run : RunResult
        An Hl-CMP run with the series "u" and "v" (T, M) [N].
    """
    return float(np.sum(np.mean(np.abs(run.series["u"] + run.series["v"]), axis=0)))


def run_trials(
    scenario: Scenario,
    dmp: Dmp,
    trials: int,
    *,
    theta0: tuple | None = None,
    reporter: Progress = SILENT,
) -> list[RunResult]:
    """Reproductions of `dmp`, each starting from the theta the previous one ended with;
    stops after an unstable trial.

    Parameters
    ----------
    scenario : Scenario
        A learning scenario (see `learning_scenario`).
    dmp : Dmp
        The reference motion.
    trials : int
    theta0 : tuple of three (M, N) arrays, optional
        The first trial's weights (default: the scenario's initial weights).
    reporter : Progress, optional

    Returns
    -------
    list of RunResult
        Named trial_1, trial_2, ...
    """
    build = diagram_factory(scenario, dmp)
    name = learner(scenario)
    runs = []
    for k in range(trials):
        run = run_one(
            build, scenario, name, label=f"trial_{k + 1}", theta0=theta0, reporter=reporter
        )
        runs.append(run)
        if run.status != "ok":
            break
        theta0 = run.theta
    return runs


def trial_metrics(runs: list[RunResult], scenario: Scenario) -> list[dict]:
    """Per trial: position error [m], mean force [N] and smoothness [N] per axis, and
    effort [N].

    Parameters
    ----------
    runs : list of RunResult
    scenario : Scenario
        The learning scenario (its experiment computes the metrics).
    """
    experiment = experiment_of(scenario)
    config = scenario.controllers[learner(scenario)]
    rows = []
    for k, run in enumerate(runs, start=1):
        m = experiment.controller_metrics(run, config, scenario)
        rows.append(
            {
                "trial": k,
                "status": run.status,
                "mean_abs_position_error_m": m["mean_abs_position_error_m"],
                "mean_abs_force_N": m["mean_abs_force_N"],
                "force_smoothness_N": m["force_smoothness_N"],
                "effort_N": effort(run),
            }
        )
    return rows


# The per-trial measures, once: (header, value of a trial row) for the table and the figure.
TRIAL_MEASURES = [
    ("mean |e|, x+y+z [mm]", lambda r: 1000 * sum(r["mean_abs_position_error_m"].values())),
    ("mean |f|, x+y+z [N]", lambda r: sum(r["mean_abs_force_N"].values())),
    ("smoothness z [N]", lambda r: r["force_smoothness_N"]["z"]),
    ("effort mean |u + v| [N]", lambda r: r["effort_N"]),
]


def improvement(rows: list[dict]) -> dict | None:
    """Whether the last trial beats the first, per measure (None with a single trial).

    Parameters
    ----------
    rows : list of dict
        From `trial_metrics`.
    """
    if len(rows) < 2:
        return None
    first, last = rows[0], rows[-1]

    def total(row, key):
        return sum(row[key].values())

    return {
        "position_error": total(last, "mean_abs_position_error_m")
        < total(first, "mean_abs_position_error_m"),
        "mean_force": total(last, "mean_abs_force_N") < total(first, "mean_abs_force_N"),
        "smoothness_z": last["force_smoothness_N"]["z"] < first["force_smoothness_N"]["z"],
        "effort": last["effort_N"] < first["effort_N"],
    }


def trials_table(learn_metrics: dict, replay_metrics: dict | None = None) -> Table:
    """The trials of `hlcmp learn` (and a frozen replay's row, when given) as a Table.

    Parameters
    ----------
    learn_metrics : dict
        The metrics.json of `hlcmp learn`.
    replay_metrics : dict, optional
        The metrics.json of `hlcmp reproduce --freeze`.
    """
    table = Table(["run"] + [header for header, _ in TRIAL_MEASURES])
    rows = [(f"learn, trial {r['trial']}", r) for r in learn_metrics["trials"]]
    if replay_metrics is not None:
        rows.append(("reproduce --freeze", replay_metrics["trials"][0]))
    for label, row in rows:
        table.add(label, *(number(value(row)) for _, value in TRIAL_MEASURES))
    return table


def trials_figure(rows: list[dict]) -> Figure:
    """The per-trial measures against the trial number, one panel each.

    Parameters
    ----------
    rows : list of dict
        From `trial_metrics`.
    """
    fig, axes = new_figure(1, len(TRIAL_MEASURES), size=(15, 3.6))
    trials = [row["trial"] for row in rows]
    for axis, (label, value) in zip(axes, TRIAL_MEASURES):
        axis.plot(trials, [value(r) for r in rows], "o-")
        axis.set_xlabel("trial")
        axis.set_title(label)
        axis.set_xticks(trials)
        axis.grid(alpha=0.3)
    fig.suptitle("Learning over repeated trials")
    return fig


@dc.dataclass
class LearningResult:
    """What `learn` and `reproduce` return: the metrics.json content, the trials' runs,
    where the files went, and the saved skill file (None when frozen or unstable)."""

    metrics: dict
    runs: list
    out_dir: Path
    skill_path: Path | None


def learn(
    scenario_name: str | Path,
    out_dir: str | Path,
    *,
    demo: str | Path | None = None,
    skill: Skill | None = None,
    skill_path: str | Path | None = None,
    trials: int = 1,
    freeze: bool = False,
    reporter: Progress = SILENT,
    overrides: Sequence[str] = (),
) -> LearningResult:
    """Learn (or, with a skill and `freeze`, replay) over `trials` reproductions.

    Parameters
    ----------
    scenario_name : str or Path
        The world: a bundled scenario or a YAML file with a demonstration and an Hl-CMP.
    out_dir : str or Path
        Where skill.npz, metrics.json, the time series, figures and recording go.
    demo : path, optional
        The user's demonstration CSV; the DMP is fitted to it. Without it the skill's DMP
        is replayed.
    skill : Skill, optional
        Start from this skill's profiles (and its DMP when no `demo` is given).
    skill_path : path, optional
        Where `skill` was read from (recorded in metrics.json).
    trials : int
        Reproductions, each continuing from the previous one's learned profiles.
    freeze : bool
        No adaptation (learning rates 0): the skill's profiles as they are.
    reporter : Progress, optional
    overrides : sequence of str
        ``dotted.key=value`` overrides of the scenario.
    """
    base, path = load_scenario(scenario_name, overrides)
    experiment = experiment_of(base, path)
    scenario = learning_scenario(base, demo, skill, freeze)
    dmp = fit_demonstration(scenario) if demo is not None or skill is None else skill.dmp
    theta0 = (skill.theta_k, skill.theta_d, skill.theta_v) if skill else None
    runs = run_trials(scenario, dmp, trials, theta0=theta0, reporter=reporter)
    rows = trial_metrics(runs, scenario)
    unstable = instability_record(runs)
    metrics = {
        "scenario": scenario.name,
        "status": "unstable" if unstable else "ok",
        "demonstration": None if demo is None else str(demo),
        "started_from_skill": None if skill_path is None else str(skill_path),
        "adaptation": "frozen" if freeze else "on",
        "trials": rows,
        "improves_over_trials": improvement(rows),
    }
    if unstable:
        metrics["instability"] = unstable
    figures = {}
    if not unstable:
        figures = experiment.figures({learner(scenario): runs[-1]}, scenario)
        figures["trials.png"] = trials_figure(rows)
    out_dir = Path(out_dir)
    saved = None
    with outputs.replacing_outputs(out_dir, keep=[skill_path] if skill_path else []):
        if not unstable and not freeze:
            saved = save_skill(out_dir / "skill.npz", Skill(dmp, *runs[-1].theta))
        write_results(out_dir, scenario, {run.controller: run for run in runs}, metrics, figures)
    return LearningResult(metrics, runs, out_dir, saved)
