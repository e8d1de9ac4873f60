"""The insertion experiment (paper Sec. V-D, Figs. 4-8) and claims C1-C4."""

import numpy as np

from hlcmp_drake.config.scenario import ArmTask, ControllerConfig, HlcmpConfig, Scenario
from hlcmp_drake.core.metrics import (
    force_smoothness,
    max_abs_force,
    mean_abs_force,
    mean_abs_position_error,
)
from hlcmp_drake.core.puncture import came_in_over_time, deep_enough_to_tear
from hlcmp_drake.experiments.claims import (
    Claim,
    ClaimInputs,
    Verdict,
    constant_impedances,
    constants_only,
    judge_claims,
    learner_and_constants,
    smoother_force,
)
from hlcmp_drake.experiments.experiment import Experiment
from hlcmp_drake.experiments.plots import bar_chart, new_figure
from hlcmp_drake.experiments.table import Table, number, per_axis
from hlcmp_drake.io.runs import RunResult
from hlcmp_drake.worlds.controllers import kind_of, learners
from hlcmp_drake.worlds.puncture import object_face

AXES = ("x", "y", "z")
CONTACT_FORCE_N = 0.5  # |f_ext| above this counts as contact
SELECTIVE_FRACTION = 0.2  # C3: "almost zero" in x/y = within 20 % of z
CHANGE_FRACTION = 0.2  # C4: a rise or fall counts when it is 20 % of the profile's peak
SMOOTHING_S = 0.25  # C4: profiles are judged after a centred moving average this long
PIERCE_LAG_S = 0.5  # C4: the profiles may peak up to this long after the pierce


def _per_axis(values):
    return {axis: float(v) for axis, v in zip(AXES, values)}


def contact_mask(run: RunResult) -> np.ndarray:
    """(T,) bool: the samples where |f_ext| exceeds CONTACT_FORCE_N (the tool is in contact).

    Parameters
    ----------
    run : RunResult
        With the series "f_ext" (T, 3) [N].
    """
    return np.linalg.norm(run.series["f_ext"], axis=1) > CONTACT_FORCE_N


def controller_metrics(run: RunResult, config: ControllerConfig, scenario: Scenario) -> dict:
    """Per axis: mean |x - x_d| [m] (Fig. 6), mean |f| [N] (Fig. 7), sum |second
    difference of f| [N] (Fig. 8), max |f| [N]; for a learning controller (an Hl-CMP
    config) also the peaks of its learned profiles and the ratio of feed-forward to
    commanded force in z.

    Parameters
    ----------
    run : RunResult
        The run's logged series (x, xd, f_ext; Ks, v, u for an Hl-CMP), each (T, M).
    config : controller config
        The run's controller config; its kind decides which metrics apply.
    scenario : Scenario

    Returns
    -------
    dict
        The controller's entry of metrics.json.
    """
    x, xd, f = run.series["x"], run.series["xd"], run.series["f_ext"]
    metrics = {
        "mean_abs_position_error_m": _per_axis(mean_abs_position_error(x, xd)),
        "mean_abs_force_N": _per_axis(mean_abs_force(f)),
        "force_smoothness_N": _per_axis(force_smoothness(f)),
        "max_abs_force_N": _per_axis(max_abs_force(f)),
    }
    if kind_of(config).learns:
        metrics["max_stiffness_N_per_m"] = _per_axis(np.max(run.series["Ks"], axis=0))
        metrics["max_abs_feedforward_N"] = _per_axis(np.max(np.abs(run.series["v"]), axis=0))
        share = feedforward_share(run, config)
        metrics["ff_to_commanded_force_ratio_z"] = None if share is None else share["measured"]
    return metrics


def went_through(run: RunResult, scenario: Scenario) -> dict:
    """The insertion's task: the tool went through the plank, i.e. the foam tore. The tear
    is the puncture model's own condition (`task.puncture`): the tool point, having come in
    through the plank's top face (from above it, then over it:
    `core.puncture.came_in_from_above`), reaching `depth_m` below it, read off the logged
    tool point, so a served run is judged as a simulated one.

    Parameters
    ----------
    run : RunResult
        Its x series (T, 3), the tool point [m].
    scenario : Scenario
        Its task's puncture (the plank's frame and the tear depth).

    Returns
    -------
    dict
        {"done", "evidence", "tear_s"}: the first logged time at the tear depth [s], or None;
        the evidence of a run that did not says where the tool point was.

    Raises
    ------
    ValueError
        Without a puncture modelled: there is no tear to judge a run by (`load_scenario`
        with the experiments' needs refuses such a scenario before any run).
    """
    face = object_face(scenario)
    if face is None:
        raise ValueError("the insertion's task is the tear: it needs task.puncture")
    tear_depth = scenario.task.puncture.depth_m
    x = run.series["x"]
    depth, over = face.depth_of(x), face.over(x)
    came_in = came_in_over_time(depth, over)
    deep_enough = deep_enough_to_tear(depth, tear_depth)
    torn = np.flatnonzero(came_in & deep_enough)
    if torn.size:
        tear_s = float(run.t[torn[0]])
        return {"done": True, "evidence": f"tore the plank at {tear_s:.2f} s", "tear_s": tear_s}
    return {
        "done": False,
        "evidence": "did not go through the plank: "
        + _where_the_tool_was(depth, over, face.beside_by(x), came_in, deep_enough, tear_depth),
        "tear_s": None,
    }


def _where_the_tool_was(depth, over, beside, came_in, deep_enough, tear_depth) -> str:
    """Why a tool point's path tore nothing -- it never came in through the top face,
    reached the tear depth only where it had not, or went not deep enough -- from its depth
    below the plank's top, whether it is over the plank, how far beside it [m], whether it
    came in and whether it is deep enough, at each sample."""
    through_the_top = (
        "the plank tears only where the tool point comes in through its top face and reaches "
        f"{1000 * tear_depth:.1f} mm below it"
    )
    if not came_in.any():
        where = "over it" if over[0] else f"{1000 * beside[0]:.1f} mm beside it"
        return (
            f"the tool point started {1000 * depth[0]:.1f} mm below its top, {where}, and "
            f"never rose above it: {through_the_top}"
        )
    under_the_face = deep_enough & over
    if under_the_face.any():
        k = int(np.argmax(np.where(under_the_face, depth, -np.inf)))
        where = "below its top under the plank only from beside or below it"
        return f"the tool point reached {1000 * depth[k]:.1f} mm {where}: {through_the_top}"
    if deep_enough.any():
        k = int(np.argmax(np.where(deep_enough, depth, -np.inf)))
        where = f"below its top only {1000 * beside[k]:.1f} mm beside it"
        return f"the tool point reached {1000 * depth[k]:.1f} mm {where}: {through_the_top}"
    deepest = float(np.max(depth[came_in]))
    reached = (
        f"reached {1000 * deepest:.1f} mm below its top"
        if deepest >= 0
        else f"stayed {-1000 * deepest:.1f} mm above its top"
    )
    return f"the tool point {reached}, the tear needs {1000 * tear_depth:.1f} mm"


def _phase_times(run: RunResult, tear_s: float | None = None):
    """(contact onset, pierce, last sample in contact) as sample indices, and whether the
    pierce is the tear; None without contact before the deepest point. The pierce is the
    tear where there is one, else the peak |f_z| before the deepest point of the reference."""
    mask = contact_mask(run)
    if not mask.any():
        return None
    deepest = int(np.argmin(run.series["xd"][:, 2]))
    onset = int(np.argmax(mask))
    if onset >= deepest:
        return None
    if tear_s is not None:
        pierce = int(np.searchsorted(run.t, tear_s))
    else:
        pierce = onset + int(np.argmax(np.abs(run.series["f_ext"][onset : deepest + 1, 2])))
    last = int(np.flatnonzero(mask)[-1])
    return onset, pierce, last, tear_s is not None


def _smoothed(values: np.ndarray, samples: int) -> np.ndarray:
    """A centred moving average over `samples` (shrinking at the ends)."""
    kernel = np.ones(max(1, samples))
    return np.convolve(values, kernel, "same") / np.convolve(np.ones_like(values), kernel, "same")


def rise_and_fall(run: RunResult, tear_s: float | None = None) -> dict | None:
    """C4 in numbers, on the contact phase only (from contact onset to the last sample in
    contact), on profiles smoothed over SMOOTHING_S: K_s,z and v_z at onset, their peak
    and when it comes, and at the end of the contact. A profile rises when its peak exceeds
    its onset value by CHANGE_FRACTION of the peak, and falls after the pierce when it peaks
    no later than PIERCE_LAG_S after the pierce and ends the contact at least
    CHANGE_FRACTION of the peak below it.

    Parameters
    ----------
    run : RunResult
        An Hl-CMP run (series Ks, v, xd, f_ext, t).
    tear_s : float, optional
        When the foam tore [s] (`went_through`): the pierce. Without it, the pierce is
        the force peak.

    Returns
    -------
    dict or None
        The phase times [s] and what the pierce is ("tear" or "force peak"); per profile
        the values [N/m, N], `rises` and `falls`; None without a contact phase.
    """
    phases = _phase_times(run, tear_s)
    if phases is None:
        return None
    onset, pierce, last, is_tear = phases
    t = run.t
    samples = int(round(SMOOTHING_S / (t[1] - t[0]))) if len(t) > 1 else 1
    out = {
        "onset_s": float(t[onset]),
        "pierce_s": float(t[pierce]),
        "pierce_is": "tear" if is_tear else "force peak",
        "contact_end_s": float(t[last]),
    }
    for key, name in (("Ks", "stiffness"), ("v", "feedforward")):
        z = _smoothed(run.series[key][onset : last + 1, 2], samples)
        top = int(np.argmax(z))
        peak = float(z[top])
        out[name] = {
            "at_onset": float(z[0]),
            "peak": peak,
            "peak_s": float(t[onset + top]),
            "at_contact_end": float(z[-1]),
            "rises": bool(peak > 0 and peak - z[0] >= CHANGE_FRACTION * peak),
            "falls": bool(
                peak > 0
                and t[onset + top] <= t[pierce] + PIERCE_LAG_S
                and peak - z[-1] >= CHANGE_FRACTION * peak
            ),
        }
    return out


def feedforward_share(run: RunResult, config: HlcmpConfig) -> dict | None:
    """The paper's v ~ f_c / 2 beside what sets it: over the contact phase, the measured
    v_z / (u_z + v_z), the mean tracking lag |e_z|, and the share Eq. 31 predicts for that
    lag, 1 / (1 + (Q_k / Q_v) e^2) (u / v ~ (Q_k / Q_v) e^2 for a slowly varying error).

    Parameters
    ----------
    run : RunResult
        An Hl-CMP run (series u, v, x, xd, f_ext).
    config : HlcmpConfig
        Its learning rates (the ratio Q_k / Q_v does not depend on their units).
    """
    mask = contact_mask(run)
    if not mask.any():
        return None
    u, v = run.series["u"][mask, 2], run.series["v"][mask, 2]
    lag = float(np.mean(np.abs(run.series["x"][mask, 2] - run.series["xd"][mask, 2])))
    ratio = config.q_k[2] / config.q_v[2] if config.q_v[2] > 0 else float("inf")
    total = float(np.mean(u + v))
    return {
        "measured": None if total == 0 else float(np.mean(v) / total),
        "mean_lag_m": lag,
        "predicted": float(1.0 / (1.0 + ratio * lag**2)),
    }


def _mean_force(metrics: dict, name: str) -> dict:
    return metrics[name]["mean_abs_force_N"]


# --- the claims (Sec. V-D): each the paper's sentence, its judge and its evidence -----


def stiffer_tracks_better(given: ClaimInputs) -> Verdict | None:
    """C1: a stiffer constant impedance tracks better (Fig. 6): the mean |x - x_d| summed
    over x, y, z falls from each constant impedance to the next stiffer one.

    Parameters
    ----------
    given : ClaimInputs
        The constant impedances are found by config kind, ordered by their configured
        stiffness; no learner is needed.

    Returns
    -------
    Verdict or None
        None with fewer than two constant impedances: no stiffer one to compare with.
    """
    constants = constant_impedances(given.scenario)
    if len(constants) < 2:
        return None
    errors = [sum(given.metrics[n]["mean_abs_position_error_m"].values()) for n in constants]
    return Verdict(
        holds=all(a > b for a, b in zip(errors, errors[1:])),
        evidence="mean |x - x_d| summed over x, y, z: "
        + ", ".join(f"{n} {e * 1000:.2f} mm" for n, e in zip(constants, errors))
        + ".",
    )


C1 = Claim(
    name="C1",
    paper_says=(
        '"We can see that larger stiffness would result in a better performance of position '
        'tracking." (Fig. 6)'
    ),
    judge=stiffer_tracks_better,
    about=constants_only,
)


def smoother_contact_force(given: ClaimInputs) -> Verdict | None:
    """C2: the Hl-CMP's contact force is smoother than every constant impedance's (z axis,
    Fig. 8; see `claims.smoother_force`).

    Parameters
    ----------
    given : ClaimInputs

    Returns
    -------
    Verdict or None
        None without the learner's metrics or a constant impedance.
    """
    if given.learner_metrics is None:
        return None
    return smoother_force(
        given.metrics,
        given.learner,
        constant_impedances(given.scenario),
        "sum |second difference of f_z|",
    )


C2 = Claim(
    name="C2",
    paper_says=(
        '"Our approach ... can allow the robot to learn compliant behaviours resulting in '
        'more smooth force profiles" (Fig. 8)'
    ),
    judge=smoother_contact_force,
    about=learner_and_constants,
)


def _small_in_xy(values: dict) -> bool:
    """x and y within SELECTIVE_FRACTION of z ("almost zero")."""
    return all(abs(values[a]) <= SELECTIVE_FRACTION * abs(values["z"]) for a in ("x", "y"))


def selective_adaptation(given: ClaimInputs) -> Verdict | None:
    """C3, as the paper judges it: the Hl-CMP's measured x/y force almost zero (and its
    learned x/y profiles small against z), while the constant impedances' is not.

    Parameters
    ----------
    given : ClaimInputs

    Returns
    -------
    Verdict or None
        With its three parts; None without the learner's metrics or a constant impedance
        (the paper's judgement compares the two).
    """
    hl = given.learner_metrics
    constants = constant_impedances(given.scenario)
    if hl is None or not constants:
        return None
    metrics, name = given.metrics, given.learner
    f, k, v = _mean_force(metrics, name), hl["max_stiffness_N_per_m"], hl["max_abs_feedforward_N"]
    parts = {
        "hlcmp_xy_force_near_zero": _small_in_xy(f),
        "hlcmp_xy_profiles_small": _small_in_xy(k) and _small_in_xy(v) and k["z"] > 0,
        "constant_xy_force_not_near_zero": all(
            not _small_in_xy(_mean_force(metrics, n)) for n in constants
        ),
    }
    return Verdict(
        holds=all(parts.values()),
        parts=parts,
        evidence=(
            f"mean |f| x/y/z: {name} "
            + "/".join(f"{f[a]:.2f}" for a in AXES)
            + " N; "
            + "; ".join(
                f"{n} " + "/".join(f"{_mean_force(metrics, n)[a]:.2f}" for a in AXES)
                for n in constants
            )
            + f" N. Learned peaks x/y/z: K_s {k['x']:.1f}/{k['y']:.1f}/{k['z']:.1f} N/m, |v| "
            f"{v['x']:.2f}/{v['y']:.2f}/{v['z']:.2f} N "
            f"(near zero: within {SELECTIVE_FRACTION:.0%} of z). Parts: "
            + ", ".join(f"{p} = {'yes' if ok else 'no'}" for p, ok in parts.items())
            + "."
        ),
    )


C3 = Claim(
    name="C3",
    paper_says=(
        '"the force profiles are almost kept zero in x and y axes, which means the proposed '
        "Hl-CMPs model can automatically decouple the dynamics profiles in different axes "
        "and then selectively adapt the task-related ones, but the fixed impedance mode "
        'could not do so." (Figs. 4, 5)'
    ),
    judge=selective_adaptation,
    about=learner_and_constants,
)


def _yes_no(value: bool) -> str:
    return "yes" if value else "no"


def rises_then_falls(given: ClaimInputs) -> Verdict | None:
    """C4: on the contact phase, smoothed, stiffness and feed-forward rise while pushing in
    and fall after the pierce (see `rise_and_fall`); v / (u + v) beside the lag that sets
    it (see `feedforward_share`).

    Parameters
    ----------
    given : ClaimInputs
        Its runs must hold the learner's; without runs, no contact phase is found.

    Returns
    -------
    Verdict or None
        With the phases and the feed-forward share as details; None without the
        learner's metrics.
    """
    if given.learner_metrics is None:
        return None
    runs, name = given.runs, given.learner
    tear_s = given.learner_metrics.get("task", {}).get("tear_s")
    phases = rise_and_fall(runs[name], tear_s) if runs else None
    if phases is None:
        return Verdict(holds=False, evidence="no contact phase found in the Hl-CMP run.")
    ks, ff = phases["stiffness"], phases["feedforward"]
    share = feedforward_share(runs[name], given.scenario.controllers[name])
    measured = "n/a" if share["measured"] is None else f"{share['measured']:.2f}"
    return Verdict(
        holds=ks["rises"] and ks["falls"] and ff["rises"] and ff["falls"],
        evidence=(
            f"contact {phases['onset_s']:.2f}-{phases['contact_end_s']:.2f} s, "
            f"{phases['pierce_is']} {phases['pierce_s']:.2f} s; "
            f"smoothed K_s,z {ks['at_onset']:.1f} -> peak "
            f"{ks['peak']:.1f} at {ks['peak_s']:.2f} s -> {ks['at_contact_end']:.1f} N/m "
            f"(rises: {_yes_no(ks['rises'])}, falls after the pierce: {_yes_no(ks['falls'])}); "
            f"v_z {ff['at_onset']:.2f} -> peak {ff['peak']:.2f} at {ff['peak_s']:.2f} s -> "
            f"{ff['at_contact_end']:.2f} N (rises: {_yes_no(ff['rises'])}, falls: "
            f"{_yes_no(ff['falls'])}). v/(u+v) in z over the contact: {measured} (paper: "
            f"about 0.5) with a mean lag |e_z| of {1000 * share['mean_lag_m']:.1f} mm, for "
            f"which Eq. 31 predicts {share['predicted']:.2f}."
        ),
        details={"phases": phases, "feedforward_share": share},
    )


C4 = Claim(
    name="C4",
    paper_says=(
        '"they slowly increase during the insertion phase ... After the tool piercing the '
        "foam plank, during the third phase the force and the impedance start to decrease "
        "since the external resistance becomes smaller ... the value of the feedforward "
        'force at each time step is almost half of that of the command force" (Fig. 4)'
    ),
    judge=rises_then_falls,
)

CLAIMS = (C1, C2, C3, C4)


def claims(
    metrics: dict, scenario: Scenario, runs: dict | None = None, learner_name: str | None = None
) -> dict:
    """C1-C4 for one learner (one reading of Q); the baselines are found by config kind,
    the constants ordered by their configured stiffness. Every verdict is recomputable
    from timeseries.npz.

    Parameters
    ----------
    metrics : dict
        Every controller's Figs. 6-8 metrics, by label.
    scenario : Scenario
        Whose configs say which label is an Hl-CMP and which are constant impedances.
    runs : dict of str to RunResult, optional
        Needed for C4, which reads the Hl-CMP's profiles over time.
    learner_name : str, optional
        The Hl-CMP to judge (default the scenario's first).

    Returns
    -------
    dict
        C1 with two or more constant impedances, C2 and C3 with a learner and a constant
        impedance, C4 with a learner: {"holds", "evidence", "paper_says"}.
    """
    return judge_claims(CLAIMS, metrics, scenario, runs, learner_name)


def table(metrics: dict) -> Table:
    """Per controller: the per-axis metrics of Figs. 6-8 and the peak z force.

    Parameters
    ----------
    metrics : dict
        {controller label: controller metrics}.
    """
    result = Table(
        [
            "controller",
            "mean |e| x/y/z [mm]",
            "mean |f| x/y/z [N]",
            "smoothness x/y/z [N]",
            "max |f_z| [N]",
        ]
    )
    for name, m in metrics.items():
        result.add(
            name,
            per_axis(m["mean_abs_position_error_m"], AXES, 1000),
            per_axis(m["mean_abs_force_N"], AXES),
            per_axis(m["force_smoothness_N"], AXES, digits=1),
            number(m["max_abs_force_N"]["z"]),
        )
    return result


def _profiles_figure(hl: RunResult, title: str):
    fig, axes = new_figure(5, 1, size=(8, 11), sharex=True)
    axes[0].plot(hl.t, hl.series["xd"][:, 2], "k--", label="reference $x_{d,z}$")
    axes[0].plot(hl.t, hl.series["x"][:, 2], label="measured $x_z$")
    axes[0].set_ylabel("z [m]")
    axes[1].plot(hl.t, hl.series["v"][:, 2], color="C2")
    axes[1].set_ylabel("FF $v_z$ [N]")
    axes[2].plot(hl.t, hl.series["Ks"][:, 2], color="C3")
    axes[2].set_ylabel("stiffness [N/m]")
    axes[3].plot(hl.t, hl.series["Kd"][:, 2], color="C4")
    axes[3].set_ylabel("damping [Ns/m]")
    axes[4].plot(
        hl.t,
        hl.series["u"][:, 2] + hl.series["v"][:, 2],
        color="C1",
        label="CF $u_z + v_z$ (Eq. 3)",
    )
    axes[4].plot(hl.t, hl.series["v"][:, 2], color="C2", lw=1, label="FF $v_z$")
    axes[4].set_ylabel("force [N]")
    axes[4].set_xlabel("time [s]")
    axes[0].set_title(title)
    for axis in axes:
        axis.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[4].legend(fontsize=8)
    return fig


def figures(runs: dict, scenario: Scenario) -> dict:
    """Figs. 4-8.

    Parameters
    ----------
    runs : dict of str to RunResult
        By label; each learner's run draws a Fig. 4.
    scenario : Scenario

    Returns
    -------
    dict of str to Figure
        fig4_profiles_z.png ... fig8_smoothness.png.
    """
    out = {}
    for k, name in enumerate(n for n in learners(scenario) if n in runs):
        # Fig. 4 for each learner (each reading of Q); the first keeps the paper's file name.
        out["fig4_profiles_z.png" if k == 0 else f"fig4_profiles_z_{name}.png"] = _profiles_figure(
            runs[name], f"{name}: Hl-CMP profiles learned online in z (paper Fig. 4)"
        )

    fig, axes = new_figure(2, 3, size=(13, 7), sharex=True)
    first = next(iter(runs.values()))
    for i, axis_name in enumerate(AXES):
        axes[i].plot(first.t, first.series["xd"][:, i], "k--", lw=1.2, label="reference")
        for name, run in runs.items():
            axes[i].plot(run.t, run.series["x"][:, i], label=name)
            axes[3 + i].plot(run.t, run.series["f_ext"][:, i], label=name)
        axes[i].set_title(f"{axis_name}: position [m]")
        axes[3 + i].set_title(f"{axis_name}: measured force [N]")
        axes[3 + i].set_xlabel("time [s]")
    for axis in axes:
        axis.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle("Endpoint position and wrist force during reproduction (paper Fig. 5)")
    out["fig5_position_force.png"] = fig

    metrics = {
        name: controller_metrics(run, scenario.controllers[name], scenario)
        for name, run in runs.items()
    }
    for file_name, key, label, scale in [
        (
            "fig6_position_error.png",
            "mean_abs_position_error_m",
            "mean |x - x_d| [mm] (paper Fig. 6)",
            1000,
        ),
        ("fig7_mean_force.png", "mean_abs_force_N", "mean |f| [N] (paper Fig. 7)", 1),
        (
            "fig8_smoothness.png",
            "force_smoothness_N",
            "sum |second difference of f| [N] (paper Fig. 8)",
            1,
        ),
    ]:
        values = {name: [m[key][a] * scale for a in AXES] for name, m in metrics.items()}
        out[file_name] = bar_chart(values, AXES, label)
    return out


EXPERIMENT = Experiment(
    name="insertion",
    title="Insertion of a rod through a foam plank (iiwa14)",
    paper_section="V-D",
    paper_figures="Figs. 4-8",
    world=ArmTask,
    controller_metrics=controller_metrics,
    claims=claims,
    table=table,
    figures=figures,
    task_done=went_through,
    needs_puncture=True,
)
