"""Table I as a user lives it: learn a skill from one's own demonstration over repeated
trials, save it, and reproduce it later (with or without further adaptation).

Each trial is one reproduction of the demonstration in the scenario's world by the
scenario's learning controller (its first Hl-CMP, found by config kind, or the one named),
starting from the theta the previous trial ended with. A 6-D Hl-CMP (`PoseHlcmpConfig`)
learns from a pose demonstration and follows its orientation DMP; its skill holds both
DMPs and the six profiles' weights (skill format 4), and a replay follows the skill's
orientation DMP. A skill whose weights do not fit the learner (a translational skill for
a 6-D Hl-CMP, or the other way round) is refused before anything is simulated.

A trial lasts as long as the skill -- the demonstration's duration, the DMP's tau (or the
scenario's `reference.duration_s` when that rescales it) -- plus SETTLE_S, whatever the
scenario's own `duration_s` is; an override ``duration_s=...`` sets it instead. A skill
records the world it was learned in (`hlcmp_drake.config.world`); using it in another
world is refused unless asked for (`any_scenario`), and a skill whose world is unknown (a
skill of `hlcmp fit`, or a format 1 file) is used with a warning. A demonstration that
carries its wrist force (fx,fy,fz) gives the skill its encoded force, from which the
first trial's feed-forward starts when asked (`demo_force`).
"""

from __future__ import annotations

import dataclasses as dc
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.scenario import DemonstrationConfig, Scenario
from hlcmp_drake.config.validation import ReplayProblem
from hlcmp_drake.config.world import world_of_scenario
from hlcmp_drake.core.demo_force import fit_feedforward_weights
from hlcmp_drake.core.dmp import Dmp
from hlcmp_drake.core.orientation_dmp import OrientationDmp
from hlcmp_drake.experiments import experiment_of
from hlcmp_drake.experiments.claims import learner
from hlcmp_drake.experiments.plots import new_figure
from hlcmp_drake.experiments.table import Table, number
from hlcmp_drake.io import outputs
from hlcmp_drake.io.demos import read_demonstration, replay_speed_problem, rollout_replay_problem
from hlcmp_drake.io.errors import InputError
from hlcmp_drake.io.runs import RunResult, instability_record
from hlcmp_drake.io.skill import ROTATIONAL_FIELDS, Skill, SkillWorld, save_skill
from hlcmp_drake.present.progress import SILENT, Progress
from hlcmp_drake.run.runner import experiment_worlds, run_one, write_results
from hlcmp_drake.worlds.arm import fit_demonstration, fit_orientation_demonstration
from hlcmp_drake.worlds.build import diagram_factory
from hlcmp_drake.worlds.controllers import controller_kind, learners

if TYPE_CHECKING:
    from matplotlib.figure import Figure

# The simulated time after the skill's end (its tau) in every trial of `learn` and
# `reproduce` [s]. It is the bundled scenarios' own (8.5 s + 1 s for the insertion, 8 s +
# 1 s for the cutting), so learning from their demonstrations runs as long as `hlcmp run`,
# and it is the time the profiles take to come to rest after tau: the phase passes the last
# basis centre at tau, and the normalized basis (N = 30, alpha_s = 4) puts 71 % of every
# profile on its last function there and, 1 s later, 99.95 % for a 6 s skill (99.8 % for
# 8.5 s, 97 % for 20 s); from then on K_s, K_d and v are that function's weights, constant
# (the README's learning section says what the arm does then). The reference is at its
# goal by then: after a 6 s insertion demonstration it stays within 0.5 mm of it from tau.
SETTLE_S = 1.0


def skill_duration(scenario: Scenario, dmp: Dmp) -> float:
    """The skill's duration in `scenario`: the DMP's tau, or the scenario's
    `reference.duration_s` when that is > 0 (the same path replayed at another tau).

    Parameters
    ----------
    scenario : Scenario
        With a DemonstrationConfig reference.
    dmp : Dmp
        The skill's (or the fitted demonstration's) DMP.

    Returns
    -------
    float
        The time the reference takes [s].
    """
    reference = scenario.reference
    scaled = reference.duration_s if isinstance(reference, DemonstrationConfig) else 0.0
    return float(scaled or dmp.tau)


def replayed_reference_problem(
    demo: str | Path | None, skill: Skill | None, skill_path: str | Path | None = None
) -> ReplayProblem | None:
    """What replaying the reference of `learn`, `reproduce` or `serve` in a duration does
    wrong: the reference is the user's demonstration when one is given, else the skill's
    DMP, else the scenario's own demonstration (None: `load_scenario` checks its file).

    Parameters
    ----------
    demo : str or Path, optional
        The user's demonstration CSV.
    skill : Skill, optional
        The skill replayed when no `demo` is given.
    skill_path : str or Path, optional
        The skill's file, named in the problem.

    Returns
    -------
    callable(duration_s) -> str or None, or None
    """
    if demo is not None:
        return partial(replay_speed_problem, demo)
    if skill is not None:
        what = f"skill {Path(skill_path).name}" if skill_path else "skill"
        return partial(rollout_replay_problem, what, skill.dmp, skill.orientation)
    return None


def sets_duration(overrides: Sequence[str | dict]) -> bool:
    """Whether the overrides set the scenario's `duration_s`.

    Parameters
    ----------
    overrides : sequence of str or dict
        As for `load_scenario`: ``key=value`` strings or {key: value} dicts.

    Returns
    -------
    bool
    """
    for override in overrides:
        keys = override if isinstance(override, dict) else [str(override).partition("=")[0]]
        if any(str(key).strip() == "duration_s" for key in keys):
            return True
    return False


def check_skill_world(skill: Skill, scenario: Scenario, any_scenario: bool = False) -> str | None:
    """Refuse a skill learned in another world than the scenario's, unless `any_scenario`.

    Parameters
    ----------
    skill : Skill
        Its `world` is where it was learned (None: unknown).
    scenario : Scenario
        Where it is about to be used (as loaded, with its overrides).
    any_scenario : bool
        Use it in another world all the same.

    Returns
    -------
    str or None
        A warning line when the skill is used unchecked (its world unknown) or in another
        world with `any_scenario`; None when it is used in its own world.

    Raises
    ------
    InputError
        The skill's world is known and is not the scenario's, and not `any_scenario`.
    """
    here = world_of_scenario(scenario)
    if skill.world is None:
        return (
            f"the skill records no world (a skill of hlcmp fit, or a file saved before "
            f"skill format 2): it is used in '{scenario.name}' unchecked"
        )
    if skill.world.same_world(here):
        return None
    what = (
        f"not in this '{here.scenario}' ({here.kind} world {here.digest[:12]}), whose models, "
        "their placement or task differ"
        if skill.world.scenario == here.scenario
        else f"not in {here.describe()}"
    )
    if not any_scenario:
        raise InputError(
            f"the skill was learned in {skill.world.describe()}, {what}; its profiles belong "
            "to that world (pass --any-scenario to use it here anyway)"
        )
    return (
        f"the skill was learned in {skill.world.describe()}, {what}; used here all the same "
        "(--any-scenario)"
    )


def learning_scenario(
    scenario: Scenario,
    demo_path: str | Path | None = None,
    skill: Skill | None = None,
    freeze: bool = False,
    controller: str | None = None,
    skill_path: str | Path | None = None,
    any_scenario: bool = False,
    warn: Callable[[str], None] | None = None,
) -> Scenario:
    """The scenario reduced to learning: only its Hl-CMP (learning rates 0 with `freeze`),
    reading `demo_path` as its demonstration, with a skill's DMP settings.

    A scenario that cannot learn at all (no demonstration, no learner) is refused first; a
    skill from another world then (`check_skill_world`: --any-scenario would use it here),
    and a skill that does not fit the learner last.

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
    controller : str, optional
        The label of the learner to keep (default: the scenario's first).
    skill_path : str or Path, optional
        The skill's file, named when it does not fit.
    any_scenario : bool
        Use a skill learned in another world all the same (`check_skill_world`).
    warn : callable(str), optional
        Given `check_skill_world`'s warning, when there is one.

    Raises
    ------
    InputError
        Without a demonstration or an Hl-CMP, when `controller` names no learner, for a
        skill from another world without `any_scenario`, or when the skill does not fit
        (`check_skill_fits`).
    """
    if not isinstance(scenario.reference, DemonstrationConfig):
        raise InputError(
            f"scenario '{scenario.name}' does not follow a demonstration; learning and "
            "reproducing skills needs one that does, such as insertion, cutting or peg_in_hole"
        )
    name = learner(scenario)
    if name is None:
        raise InputError(
            f"scenario '{scenario.name}' has no learning controller (e.g. !HlcmpConfig) to learn "
            "with"
        )
    if controller is not None:
        if controller not in learners(scenario):
            raise InputError(
                f"--controller {controller}: scenario '{scenario.name}' has no learning "
                f"controller of that label (its learners: {', '.join(learners(scenario))})"
            )
        name = controller
    if skill is not None:
        # After what no skill could change (--any-scenario would not help there), and
        # before the axes: a skill from another world is refused for that.
        warning = check_skill_world(skill, scenario, any_scenario)
        if warning is not None and warn is not None:
            warn(warning)
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
        try:
            check_skill_fits(skill, scenario, name)
        except InputError as error:
            raise InputError(f"{skill_path}: {error}" if skill_path else str(error)) from None
        # The skill's basis and transformation system; the scenario's smoothing for a new demo.
        settings = dc.replace(skill.dmp.settings, smoothing_s=scenario.dmp.smoothing_s)
    return dc.replace(scenario, controllers={name: config}, reference=reference, dmp=settings)


def check_skill_fits(skill: Skill, scenario: Scenario, name: str | None = None) -> None:
    """Raise InputError when the skill's weights do not fit the learner `name` -- a 6-D
    Hl-CMP takes a 6-D skill (`Skill.six_d`), a translational one a skill of positions
    only -- or when its axes are not the ones the scenario controls.

    Parameters
    ----------
    skill : Skill
    scenario : Scenario
    name : str, optional
        The learner's label (default: the scenario's first learner).
    """
    name = name or learner(scenario)
    six_d = name is not None and controller_kind(scenario, name).pose
    if six_d and not skill.six_d:
        has = "a pose skill of format 3" if skill.orientation else "a translational skill"
        raise InputError(
            f"the skill holds no rotational profiles ({has}), and the controller '{name}' of "
            f"'{scenario.name}' is a 6-D Hl-CMP: give it a skill learned by a 6-D Hl-CMP, or "
            "one that hlcmp fit made of a pose demonstration"
        )
    if not six_d and skill.orientation is not None:
        what = "a 6-D skill" if skill.six_d else "a pose skill"
        raise InputError(
            f"the skill has an orientation ({what}), and the controller '{name}' of "
            f"'{scenario.name}' controls the translation only; a 6-D Hl-CMP "
            "(!PoseHlcmpConfig) replays it, and hlcmp rollout rolls it out"
        )
    axes = ("x", "y", "z")[: scenario.n_axes]
    if skill.dmp.axis_names != axes:
        raise InputError(
            f"the skill's axes ({','.join(skill.dmp.axis_names)}) do not match the "
            f"scenario '{scenario.name}', which controls {','.join(axes)}"
        )


def demonstration_force(scenario: Scenario) -> np.ndarray | None:
    """The learning scenario's demonstration force encoded as feed-forward weights
    (`fit_feedforward_weights`, on the scenario's basis), or None when its demonstration
    has no force columns.

    Parameters
    ----------
    scenario : Scenario
        A learning scenario (`learning_scenario`), its reference the demonstration.

    Returns
    -------
    (M, N) array or None
        theta_v [N] whose profile follows the demonstrated force.
    """
    # Its orientation, if any, is the orientation DMP's (fitted and checked elsewhere).
    t, _, _, _, force = read_demonstration(
        scenario.reference.file, with_orientation=True, with_force=True
    )
    return None if force is None else fit_feedforward_weights(t, force, scenario.dmp)


def demo_force_start(scenario: Scenario, demo_force: np.ndarray) -> tuple:
    """The first trial's weights when the feed-forward starts from the demonstration:
    theta_k and theta_d as the learner's config sets them, theta_v = `demo_force` (and a
    6-D learner's rotational weights as its config sets them).

    Parameters
    ----------
    scenario : Scenario
        A learning scenario; its learner's theta_k0, theta_d0.
    demo_force : (M, N) array
        The demonstration's encoded force [N] (`demonstration_force`).

    Returns
    -------
    tuple of three (M, N) arrays (then three (3, N) arrays for a 6-D learner)
        (theta_k, theta_d, theta_v) at t0 (then theta_kr, theta_dr, theta_vr).
    """
    name = learner(scenario)
    config = scenario.controllers[name]
    shape = np.shape(demo_force)
    start = (
        np.full(shape, float(config.theta_k0)),
        np.full(shape, float(config.theta_d0)),
        np.array(demo_force, dtype=float),
    )
    if not controller_kind(scenario, name).pose:
        return start
    rotational = (config.theta_kr0, config.theta_dr0, config.theta_vr0)
    return start + tuple(np.full((3, shape[1]), float(value)) for value in rotational)


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
    orientation_dmp: OrientationDmp | None = None,
    replay_problem: ReplayProblem | None = None,
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
    theta0 : tuple of arrays, optional
        The first trial's weights (default: the scenario's initial weights): three (M, N)
        arrays, and three (3, N) after them for a 6-D learner.
    reporter : Progress, optional
    orientation_dmp : OrientationDmp, optional
        A 6-D learner's reference orientation (default: fitted to the demonstration).
    replay_problem : callable(duration_s) -> str or None, optional
        What replaying the reference in `reference.duration_s` does wrong, where that is
        not the scenario's demonstration file (`replayed_reference_problem`).

    Returns
    -------
    list of RunResult
        Named trial_1, trial_2, ...
    """
    build = diagram_factory(scenario, dmp, orientation_dmp, replay_problem)
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


# Per-trial measures of the tool's orientation, kept where the experiment reports them
# (peg_in_hole: per tool axis).
ORIENTATION_TRIAL_MEASURES = ("mean_abs_orientation_error_rad", "max_abs_torque_Nm")


def trial_metrics(runs: list[RunResult], scenario: Scenario) -> list[dict]:
    """Per trial: position error [m], mean force [N] and smoothness [N] per axis, and
    effort [N]; the ORIENTATION_TRIAL_MEASURES the experiment reports; and whether it did
    the experiment's task (`task`, the experiment's `task_done`).

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
                **{key: m[key] for key in ORIENTATION_TRIAL_MEASURES if key in m},
                "task": experiment.task_done(run, scenario),
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


def run_label(metrics: dict, trial: int) -> str:
    """How a trial of `learn` or `reproduce` is labelled in tables: "learn, trial K",
    "reproduce" or "reproduce --freeze".

    Parameters
    ----------
    metrics : dict
        A metrics.json of `learn` or `reproduce` (one without "command" is a learn's).
    trial : int
        The trial's number, from 1.

    Returns
    -------
    str
    """
    if metrics.get("command", "learn") == "reproduce":
        return "reproduce --freeze" if metrics.get("adaptation") == "frozen" else "reproduce"
    return f"learn, trial {trial}"


def trials_table(metrics: dict, replay_metrics: dict | None = None) -> Table:
    """The trials of `hlcmp learn` or `hlcmp reproduce` (and a replay's row, when given)
    as a Table, each row labelled by the command that ran it (`run_label`).

    Parameters
    ----------
    metrics : dict
        The metrics.json of `hlcmp learn` or `hlcmp reproduce`.
    replay_metrics : dict, optional
        The metrics.json of `hlcmp reproduce --freeze`, a row after the trials.
    """
    table = Table(["run"] + [header for header, _ in TRIAL_MEASURES] + ["task done"])
    rows = [(run_label(metrics, r["trial"]), r) for r in metrics["trials"]]
    if replay_metrics is not None:
        replay = {"command": "reproduce", **replay_metrics}
        rows.append((run_label(replay, 1), replay_metrics["trials"][0]))
    for label, row in rows:
        done = row["task"]["done"] if "task" in row else None  # unknown to an older file
        table.add(
            label,
            *(number(value(row)) for _, value in TRIAL_MEASURES),
            {True: "yes", False: "no", None: "-"}[done],
        )
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
    where the files went, the saved skill file (None when frozen or unstable) and the
    warnings given (each also in metrics.json)."""

    metrics: dict
    runs: list
    out_dir: Path
    skill_path: Path | None
    warnings: list[str] = dc.field(default_factory=list)


def learn(
    scenario_name: str | Path,
    out_dir: str | Path,
    *,
    demo: str | Path | None = None,
    skill: Skill | None = None,
    skill_path: str | Path | None = None,
    trials: int = 1,
    freeze: bool = False,
    any_scenario: bool = False,
    demo_force: bool = False,
    controller: str | None = None,
    reporter: Progress = SILENT,
    overrides: Sequence[str] = (),
    warn: Callable[[str], None] | None = None,
) -> LearningResult:
    """Learn (or, with a skill and `freeze`, replay) over `trials` reproductions.

    Each trial lasts the skill's duration (`skill_duration`) plus SETTLE_S, unless the
    overrides set ``duration_s``. The skill saved records the scenario's world.

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
    any_scenario : bool
        Use a skill learned in another world all the same (`check_skill_world`).
    demo_force : bool
        Start the first trial's feed-forward theta_v from the demonstration's force
        (`demo_force_start`) instead of the learner's theta_v0.
    controller : str, optional
        The label of the learner that learns (default: the scenario's first learner). A
        6-D one (`PoseHlcmpConfig`) needs a pose demonstration (t,x,y,z,qw,qx,qy,qz).
    reporter : Progress, optional
    overrides : sequence of str
        ``dotted.key=value`` overrides of the scenario.
    warn : callable(str), optional
        Told each warning line before anything is simulated (e.g. a skill whose world
        is unknown).

    Raises
    ------
    InputError
        Before anything is simulated: a bad scenario or demonstration, a skill that does
        not fit the learner (`check_skill_fits`) or the scenario's axes, or one learned in
        another world; a demonstration without orientations for a 6-D learner; with
        `demo_force`, a demonstration without force columns, or a `skill` as well.
    """
    if demo_force and skill is not None:
        raise InputError(
            "--demo-force starts the feed-forward from the demonstration, --skill from a "
            "skill: give one of them"
        )
    return _learn_or_reproduce(
        "learn",
        scenario_name,
        out_dir,
        demo=demo,
        skill=skill,
        skill_path=skill_path,
        trials=trials,
        freeze=freeze,
        any_scenario=any_scenario,
        demo_force=demo_force,
        controller=controller,
        reporter=reporter,
        overrides=overrides,
        warn=warn,
    )


def reproduce(
    scenario_name: str | Path,
    out_dir: str | Path,
    skill: Skill,
    *,
    skill_path: str | Path | None = None,
    freeze: bool = False,
    any_scenario: bool = False,
    controller: str | None = None,
    reporter: Progress = SILENT,
    overrides: Sequence[str] = (),
    warn: Callable[[str], None] | None = None,
) -> LearningResult:
    """Replay a skill once in a scenario: its DMPs and profiles, adapting on (a skill.npz
    is saved) or off with `freeze`.

    The run lasts the skill's duration (`skill_duration`) plus SETTLE_S, unless the
    overrides set ``duration_s``.

    Parameters
    ----------
    scenario_name : str or Path
        A bundled scenario or a YAML file with a demonstration and an Hl-CMP.
    out_dir : str or Path
        Where metrics.json, the time series, figures, recording (and skill.npz unless
        `freeze`) go.
    skill : Skill
        The skill to replay.
    skill_path : path, optional
        Where `skill` was read from (recorded in metrics.json).
    freeze : bool
        No adaptation (learning rates 0): the skill's profiles as they are.
    any_scenario : bool
        Replay a skill learned in another world all the same (`check_skill_world`).
    controller : str, optional
        The label of the learner that replays it (default: the scenario's first learner).
    reporter : Progress, optional
    overrides : sequence of str
        ``dotted.key=value`` overrides of the scenario.
    warn : callable(str), optional
        Told each warning line before anything is simulated.

    Raises
    ------
    InputError
        Before anything is simulated: a bad scenario, a skill that does not fit the
        learner (`check_skill_fits`) or the scenario's axes, or one learned in another
        world.
    """
    return _learn_or_reproduce(
        "reproduce",
        scenario_name,
        out_dir,
        demo=None,
        skill=skill,
        skill_path=skill_path,
        trials=1,
        freeze=freeze,
        any_scenario=any_scenario,
        demo_force=False,
        controller=controller,
        reporter=reporter,
        overrides=overrides,
        warn=warn,
    )


def _learn_or_reproduce(
    command,
    scenario_name,
    out_dir,
    *,
    demo,
    skill,
    skill_path,
    trials,
    freeze,
    any_scenario,
    demo_force,
    controller,
    reporter,
    overrides,
    warn,
):
    replay_problem = replayed_reference_problem(demo, skill, skill_path)
    base, path = load_scenario(
        scenario_name, overrides, experiment_worlds(), replay_problem=replay_problem
    )
    experiment = experiment_of(base, path)
    warnings: list[str] = []
    scenario = learning_scenario(
        base, demo, skill, freeze, controller, skill_path, any_scenario, warnings.append
    )
    six_d = controller_kind(scenario, learner(scenario)).pose
    # The skill keeps the force of the demonstration its DMP comes from.
    if demo is not None or skill is None:
        dmp, encoded_force = fit_demonstration(scenario), demonstration_force(scenario)
        orientation = fit_orientation_demonstration(scenario) if six_d else None
        if six_d and orientation is None:
            raise InputError(
                f"{scenario.reference.file}: no orientation columns (qw,qx,qy,qz): the "
                f"controller '{learner(scenario)}' is a 6-D Hl-CMP, which learns along the "
                "demonstrated orientation"
            )
    else:
        dmp, encoded_force, orientation = skill.dmp, skill.demo_force, skill.orientation
    if demo_force and encoded_force is None:
        raise InputError(
            f"{scenario.reference.file}: no force columns (fx,fy,fz) to start the "
            "feed-forward from (--demo-force)"
        )
    tau = skill_duration(scenario, dmp)
    if not sets_duration(overrides):
        scenario = dc.replace(scenario, duration_s=tau + SETTLE_S)
    for warning in warnings:
        if warn is not None:
            warn(warning)
    world = world_of_scenario(base, overrides)
    theta0 = skill.theta if skill else None
    if demo_force:
        theta0 = demo_force_start(scenario, encoded_force)
    runs = run_trials(
        scenario,
        dmp,
        trials,
        theta0=theta0,
        reporter=reporter,
        orientation_dmp=orientation,
        replay_problem=replay_problem,
    )
    rows = trial_metrics(runs, scenario)
    unstable = instability_record(runs)
    metrics = {
        "command": command,
        "scenario": scenario.name,
        "controller": learner(scenario),
        "overrides": [str(override) for override in overrides],
        "world": dc.asdict(world),
        "status": "unstable" if unstable else "ok",
        "demonstration": None if demo is None else str(demo),
        "started_from_skill": None if skill_path is None else str(skill_path),
        "feedforward_from_demo_force": bool(demo_force),
        "skill_world": _world_record(skill),
        "adaptation": "frozen" if freeze else "on",
        "duration_s": scenario.duration_s,
        "skill_duration_s": tau,
        "settle_s": None if sets_duration(overrides) else SETTLE_S,
        "trials": rows,
        "improves_over_trials": improvement(rows),
    }
    if warnings:
        metrics["warnings"] = warnings
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
            saved = save_skill(
                out_dir / "skill.npz",
                _learned_skill(runs[-1], dmp, orientation, world, encoded_force, tau),
            )
        write_results(out_dir, scenario, {run.controller: run for run in runs}, metrics, figures)
    return LearningResult(metrics, runs, out_dir, saved, warnings)


def _learned_skill(run, dmp, orientation, world, demo_force, tau) -> Skill:
    """The skill a learner's last trial ended with: its DMPs and weights (a 6-D learner's
    six), in the world it learned in, at the tau it ran at (the demonstration's, or the
    scenario's `reference.duration_s`), so that a replay runs it as it was learned."""
    theta_k, theta_d, theta_v, *rotational = run.theta
    return Skill(
        dc.replace(dmp, tau=tau),
        theta_k,
        theta_d,
        theta_v,
        world=world,
        orientation=dc.replace(orientation, tau=tau) if rotational else None,
        demo_force=demo_force,
        **dict(zip(ROTATIONAL_FIELDS, rotational)),
    )


def _world_record(skill: Skill | None) -> dict | str | None:
    """metrics.json's record of where the skill used was learned."""
    if skill is None:
        return None
    world: SkillWorld | None = skill.world
    return "unknown" if world is None else dc.asdict(world)
