"""The cutting experiment (paper Sec. V-E, Figs. 11-12) and claims C2, C3 for cutting.

The per-axis metrics are the insertion's (Figs. 6-8 there, Fig. 12b here)."""

import numpy as np

from hlcmp_drake.config.scenario import ArmTask, Scenario
from hlcmp_drake.experiments.claims import (
    Claim,
    ClaimInputs,
    Verdict,
    constant_impedances,
    judge_claims,
    learner,
    learner_and_constants,
    smoother_force,
)
from hlcmp_drake.experiments.experiment import Experiment
from hlcmp_drake.experiments.insertion import AXES, controller_metrics, table
from hlcmp_drake.experiments.plots import new_figure
from hlcmp_drake.io.runs import RunResult

# The task, "the cut reached its depth along its length": the cut stroke is where the
# reference is at its deepest (within STROKE_BAND_M); the blade is at depth within
# DEPTH_TOLERANCE_M of it -- a third of the demonstrated 15 mm cut -- and it must be so over
# at least STROKE_FRACTION of the stroke's length.
STROKE_BAND_M = 0.001
DEPTH_TOLERANCE_M = 0.005
STROKE_FRACTION = 0.9


def cut_done(run: RunResult, scenario: Scenario) -> dict:
    """Whether the blade cut at the demonstrated depth along the cut's length.

    The stroke is read off the reference the run logged, so the run must have lasted until
    the reference's cut was over (it rose again from its deepest stretch); a run that ended
    before did not do the task, however much of the stroke it had seen covered.

    Parameters
    ----------
    run : RunResult
        Its t (T,) [s], x and xd series (T, 3) [m]; the cut runs along y at the
        reference's deepest z.
    scenario : Scenario
        Unused: the stroke is read off the reference.

    Returns
    -------
    dict
        {"done", "evidence", "stroke_covered"}: the fraction of the stroke's length [-] over
        which the blade was at depth (None when the run ended before the cut did).
    """
    x, xd = run.series["x"], run.series["xd"]
    deepest = float(xd[:, 2].min())
    stroke = xd[:, 2] <= deepest + STROKE_BAND_M
    if not np.any(xd[np.flatnonzero(stroke)[-1] :, 2] > deepest + STROKE_BAND_M):
        return {
            "done": False,
            "evidence": f"the run ended at t = {float(run.t[-1]):.2f} s, before the "
            "reference's cut did (it had not risen from its deepest stretch)",
            "stroke_covered": None,
        }
    start, end = float(xd[stroke, 1].min()), float(xd[stroke, 1].max())
    at_depth = x[:, 2] <= deepest + DEPTH_TOLERANCE_M
    covered = 0.0
    if at_depth.any() and end > start:
        along = np.clip(x[at_depth, 1], start, end)
        covered = float((along.max() - along.min()) / (end - start))
    done = covered >= STROKE_FRACTION
    shortfall = 1000 * (float(x[:, 2].min()) - deepest)
    evidence = (
        f"cut at depth (within {1000 * DEPTH_TOLERANCE_M:.0f} mm) over {100 * covered:.0f} % "
        f"of the {100 * (end - start):.0f} cm stroke"
    )
    if not done:  # say which of the two it missed
        evidence += (
            f"; its deepest point stayed {shortfall:.1f} mm above the reference's"
            if not at_depth.any()
            else f", short of the {100 * STROKE_FRACTION:.0f} % the task needs"
        )
    return {"done": done, "evidence": evidence, "stroke_covered": covered}


# --- the claims (Sec. V-E): each the paper's sentence, its judge and its evidence -----


def smoother_cutting_force(given: ClaimInputs) -> Verdict | None:
    """C2 for cutting: the Hl-CMP's z force is smoother than every constant impedance's
    (Fig. 12b; see `claims.smoother_force`).

    Parameters
    ----------
    given : ClaimInputs

    Returns
    -------
    Verdict or None
        None without a learner or a constant impedance.
    """
    if given.learner is None:
        return None
    return smoother_force(
        given.metrics,
        given.learner,
        constant_impedances(given.scenario),
        "sum |second difference of f_z| (Fig. 12b)",
    )


C2 = Claim(
    name="C2",
    paper_says=(
        '"Compared with the constant stiffness impedance control, our approach enables a '
        "more compliant cutting behaviour which is illustrated by a more smooth force "
        'profile." (Fig. 12b)'
    ),
    judge=smoother_cutting_force,
    about=learner_and_constants,
)


def adapts_most_where_hardest(given: ClaimInputs) -> Verdict | None:
    """C3 for cutting: the profiles adapt most on the axis where the task pushes back most
    (Fig. 11): the peak learned stiffness and the peak |feed-forward| are largest on the
    axis of the largest mean |f|.

    Parameters
    ----------
    given : ClaimInputs

    Returns
    -------
    Verdict or None
        None without a learner.
    """
    if given.learner is None:
        return None
    hl = given.metrics[given.learner]
    force = hl["mean_abs_force_N"]
    hardest = max(AXES, key=force.get)
    k, v = hl["max_stiffness_N_per_m"], hl["max_abs_feedforward_N"]
    most_k, most_v = max(AXES, key=k.get), max(AXES, key=v.get)
    return Verdict(
        holds=most_k == hardest and most_v == hardest,
        evidence=(
            f"mean |f| x/y/z {force['x']:.2f}/{force['y']:.2f}/{force['z']:.2f} N "
            f"(hardest: {hardest}); "
            f"peak learned stiffness x/y/z {k['x']:.1f}/{k['y']:.1f}/{k['z']:.1f} N/m "
            f"(most: {most_k}); "
            f"peak |feed-forward| x/y/z {v['x']:.2f}/{v['y']:.2f}/{v['z']:.2f} N (most: {most_v})."
        ),
    )


C3 = Claim(
    name="C3",
    paper_says=(
        '"the compliant profiles in x and z directions do not adapt as obviously as in y '
        "direction. This may be explained by the fact that the task dynamics in y axis is "
        'more difficult" (Fig. 11)'
    ),
    judge=adapts_most_where_hardest,
)

CLAIMS = (C2, C3)


def claims(
    metrics: dict, scenario: Scenario, runs: dict | None = None, learner_name: str | None = None
) -> dict:
    """C2 and C3 for cutting; without a learner, no claims.

    Parameters
    ----------
    metrics : dict
        The insertion's per-axis metrics, for each label.
    scenario : Scenario
        The learner and the constant impedances are read off its configs.
    runs : dict, optional
        Not needed for cutting's claims.
    learner_name : str, optional
        The Hl-CMP to judge (default the scenario's first).

    Returns
    -------
    dict
        {"C2": ..., "C3": ...}, each {"holds", "evidence", "paper_says"}.
    """
    return judge_claims(CLAIMS, metrics, scenario, runs, learner_name)


def figures(runs: dict, scenario: Scenario) -> dict:
    """Figs. 11 and 12.

    Parameters
    ----------
    runs : dict of str to RunResult
        By label; the Hl-CMP's run draws Fig. 11.
    scenario : Scenario

    Returns
    -------
    dict
        fig11_profiles_xyz.png and fig12_force_z_smoothness.png as Figures.
    """
    out = {}
    hl = runs.get(learner(scenario))
    if hl is not None:
        rows = [
            ("position [m]", None),
            ("FF v [N]", "v"),
            ("stiffness [N/m]", "Ks"),
            ("damping [Ns/m]", "Kd"),
            ("CF u + v [N]", "cf"),
        ]
        fig, axes = new_figure(len(rows), 3, size=(13, 11), sharex=True)
        for col, axis_name in enumerate(AXES):
            for row, (label, key) in enumerate(rows):
                axis = axes[row * 3 + col]
                if key is None:
                    axis.plot(hl.t, hl.series["xd"][:, col], "k--", label="reference")
                    axis.plot(hl.t, hl.series["x"][:, col], label="measured")
                    axis.set_title(f"{axis_name} axis")
                elif key == "cf":
                    axis.plot(hl.t, hl.series["u"][:, col] + hl.series["v"][:, col], color="C1")
                else:
                    axis.plot(hl.t, hl.series[key][:, col], color=f"C{row + 1}")
                if col == 0:
                    axis.set_ylabel(label)
                axis.grid(alpha=0.3)
        axes[0].legend(fontsize=8)
        for col in range(3):
            axes[(len(rows) - 1) * 3 + col].set_xlabel("time [s]")
        fig.suptitle("Hl-CMP profiles learned online while cutting (paper Fig. 11)")
        out["fig11_profiles_xyz.png"] = fig

    fig, axes = new_figure(1, 2, size=(13, 4.5))
    for name, run in runs.items():
        axes[0].plot(run.t, run.series["f_ext"][:, 2], label=name)
    axes[0].set_xlabel("time [s]")
    axes[0].set_ylabel("measured force f_z [N]")
    axes[0].set_title("(a) endpoint force in z")
    axes[0].grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    smooth = [
        controller_metrics(run, scenario.controllers[name], scenario)["force_smoothness_N"]["z"]
        for name, run in runs.items()
    ]
    axes[1].bar(range(len(runs)), smooth, color=[f"C{i}" for i in range(len(runs))])
    axes[1].set_xticks(range(len(runs)), list(runs))
    axes[1].set_ylabel("sum |second difference of f_z| [N]")
    axes[1].set_title("(b) smoothness (smaller is smoother)")
    axes[1].grid(alpha=0.3, axis="y")
    fig.suptitle("Cutting: measured z force (paper Fig. 12)")
    out["fig12_force_z_smoothness.png"] = fig
    return out


EXPERIMENT = Experiment(
    name="cutting",
    title="Cutting a soft block (iiwa14)",
    paper_section="V-E",
    paper_figures="Figs. 11-12",
    world=ArmTask,
    controller_metrics=controller_metrics,
    claims=claims,
    table=table,
    figures=figures,
    task_done=cut_done,
)
