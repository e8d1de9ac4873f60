"""The 1-DOF comparison (paper Sec. V-B, Fig. 13) and claim C5."""

import numpy as np

from hlcmp_drake.config.scenario import ControllerConfig, Scenario, SliderTask
from hlcmp_drake.core.metrics import settle_time, value_at
from hlcmp_drake.experiments.claims import Claim, ClaimInputs, Verdict, judge_claims
from hlcmp_drake.experiments.experiment import Experiment
from hlcmp_drake.experiments.plots import controller_colors, new_figure
from hlcmp_drake.experiments.table import Table, number
from hlcmp_drake.io.runs import RunResult
from hlcmp_drake.worlds.controllers import FORCE_TRACKING, labels_with_role, learners

DEPTH_TOLERANCE_M = 0.005


def _segments(scenario):
    """(target depth, its start time, return target, return start) from the steps; the
    last two None for a reference of one step (nothing to return to)."""
    times, positions = scenario.reference.times_s, scenario.reference.positions_m
    if len(times) < 2:
        return positions[0][0], times[0], None, None
    return positions[0][0], times[0], positions[1][0], times[1]


def controller_metrics(run: RunResult, config: ControllerConfig, scenario: Scenario) -> dict:
    """position_at_10s_m, final_position_m, reach_time_s (absolute time), return_time_s
    (seconds after the return command at t = 10 s); None where never settled, and
    position_at_10s_m None for a run that ends before 10 s (C5 is then not judged).

    Parameters
    ----------
    run : RunResult
        Only its "x" series (T, 1) [m] is read.
    config : controller config
        Unused: every controller gets the same four numbers.
    scenario : Scenario
        Its step reference gives the depth, the return target and their times.

    Returns
    -------
    dict
        x(10 s) and the final x [m], the reach and return times [s].
    """
    depth, t0, home, t_return = _segments(scenario)
    x = run.series["x"][:, 0]
    end = scenario.duration_s + 1e-9
    reach = settle_time(
        run.t, x, depth, DEPTH_TOLERANCE_M, t0, end if t_return is None else t_return
    )
    if t_return is None:  # one step: no return command, no x(10 s)
        return {
            "position_at_10s_m": None,
            "final_position_m": float(x[-1]),
            "reach_time_s": reach,
            "return_time_s": None,
        }
    back = settle_time(run.t, x, home, DEPTH_TOLERANCE_M, t_return, end)
    ends_before_return = run.t[-1] < t_return - 1e-9  # e.g. --set duration_s=2: there is no x(10 s)
    return {
        "position_at_10s_m": None if ends_before_return else value_at(run.t, x, t_return),
        "final_position_m": float(x[-1]),
        "reach_time_s": reach,
        "return_time_s": None if back is None else back - t_return,
    }


def reached_the_return(run: RunResult, scenario: Scenario) -> dict:
    """The 1-DOF task: the run lasted through the return, given as long as the segment
    before it (Fig. 13: 10 s to the depth, 10 s back), so the depth and the return are
    each measured over a window of the same length. A run that stops earlier is cut short
    of the return it would be judged on ("return never" for want of time).

    Parameters
    ----------
    run : RunResult
    scenario : Scenario
        Its reference's steps.

    Returns
    -------
    dict
        {"done", "evidence"}.
    """
    _, start, _, return_start = _segments(scenario)
    if return_start is None:
        return {"done": False, "evidence": "the reference has one step: no return command"}
    return_end = 2 * return_start - start
    end = float(run.t[-1])
    ran = f"ran {end:.2f} s"
    # Half a microsecond: the logged times of a run that lasts to the end are sums of steps.
    if end >= return_end - 5e-7:
        evidence = f"{ran}, through the return from {return_start:g} to {return_end:g} s"
    elif end < return_start:
        evidence = f"{ran}, ended before the return command at {return_start:g} s"
    else:
        evidence = (
            f"{ran}, ended before the return's end at {return_end:g} s (the return gets as "
            f"long as the segment before it, {return_start - start:g} s)"
        )
    return {"done": end >= return_end - 5e-7, "evidence": evidence}


def _fmt(value):
    return "never" if value is None else f"{value:.2f} s"


def _faster(a, b):
    """a strictly faster than b, where None means never."""
    return a is not None and (b is None or a < b)


# --- the claim (Sec. V-B): the paper's sentence, its judge and its evidence ----------


def faster_than_force_tracking(given: ClaimInputs) -> Verdict | None:
    """C5: the Hl-CMP reaches the desired depth and returns faster than [21]; [21] with an
    improper f_d fails to reach the depth (0.5 N too shallow, 5 N too deep).

    The [21] runs are found by their config kind; the one with the smallest desired force
    must stop too shallow, the one with the largest too deep, and the Hl-CMP is compared
    with the one that stops nearest the depth.

    Parameters
    ----------
    given : ClaimInputs
        Reach and return times and x(10 s) of every controller; the scenario's step
        reference sets the depth.

    Returns
    -------
    Verdict or None
        With its six parts; not judged (`holds` None) when a run ends before the return
        command; None without a learner or a [21] run.
    """
    metrics, scenario = given.metrics, given.scenario
    depth, _, _, t_return = _segments(scenario)
    vic = {name: metrics[name] for name in labels_with_role(scenario, FORCE_TRACKING)}
    if given.learner is None or not vic:
        return None  # nothing to compare: C5 needs a learner and a [21] run
    hl = metrics[given.learner]
    if any(m["position_at_10s_m"] is None for m in metrics.values()):
        # A run that ended before the return command did not do the 1-DOF task
        # (`reached_the_return`): `judge_claims` says "not judged" with its evidence.
        return Verdict(holds=None, evidence="a run ended before the return command")
    by_force = sorted(vic, key=lambda n: sum(scenario.controllers[n].desired_force_N))
    weakest, strongest = by_force[0], by_force[-1]
    proper = min(vic, key=lambda n: abs(vic[n]["position_at_10s_m"] - depth))
    parts = {
        "hlcmp_reaches_depth": hl["reach_time_s"] is not None,
        "hlcmp_returns": hl["return_time_s"] is not None,
        "hlcmp_reaches_faster_than_best_vic": _faster(
            hl["reach_time_s"], vic[proper]["reach_time_s"]
        ),
        "hlcmp_returns_faster_than_best_vic": _faster(
            hl["return_time_s"], vic[proper]["return_time_s"]
        ),
        f"{weakest}_too_shallow": vic[weakest]["position_at_10s_m"] > depth + DEPTH_TOLERANCE_M,
        f"{strongest}_too_deep": vic[strongest]["position_at_10s_m"] < depth - DEPTH_TOLERANCE_M,
    }
    lines = [
        f"Hl-CMP: x({t_return:g} s) = {hl['position_at_10s_m']:.4f} m (target {depth} m), reach "
        f"{_fmt(hl['reach_time_s'])}, return {_fmt(hl['return_time_s'])} after t = {t_return:g} s."
    ]
    for name, m in vic.items():
        lines.append(
            f"{name}: x({t_return:g} s) = {m['position_at_10s_m']:.4f} m, "
            f"reach {_fmt(m['reach_time_s'])}, "
            f"return {_fmt(m['return_time_s'])}."
        )
    lines.append(
        f"Best-placed [21] run: {proper}. Parts: "
        + ", ".join(f"{k} = {'yes' if v else 'no'}" for k, v in parts.items())
        + "."
    )
    return Verdict(holds=all(parts.values()), parts=parts, evidence=" ".join(lines))


C5 = Claim(
    name="C5",
    paper_says=(
        '"the predefined desired force fd has a large influence on the control performance '
        "and an improper value may result in the failures of tracking of the desired "
        "position. Even with an proper fd that allows the desired cutting depth, it cannot "
        'achieve a fast response compared to our approach." (Fig. 13)'
    ),
    judge=faster_than_force_tracking,
    about=lambda given: [given.learner, *labels_with_role(given.scenario, FORCE_TRACKING)],
    keys=("holds", "paper_says", "parts", "evidence"),  # C5's order in metrics.json
)

CLAIMS = (C5,)


def claims(
    metrics: dict, scenario: Scenario, runs: dict | None = None, learner_name: str | None = None
) -> dict:
    """C5 (see `faster_than_force_tracking`); not judged (task not done) when a run ends
    before its return's end at 20 s (`reached_the_return`).

    Parameters
    ----------
    metrics : dict
        Reach and return times and x(10 s) of every controller, by label.
    scenario : Scenario
        Its step reference sets the depth; its configs tell the Hl-CMP from the [21] runs.
    runs : dict, optional
        Not needed: C5 reads the metrics only.
    learner_name : str, optional
        The Hl-CMP to judge (default the scenario's first).

    Returns
    -------
    dict
        {"C5": {"holds", "paper_says", "parts", "evidence"}} ("holds" None when not
        judged), or {} without a learner or a [21] run.
    """
    return judge_claims(CLAIMS, metrics, scenario, runs, learner_name)


def table(metrics: dict) -> Table:
    """Per controller: x at 10 s, the final x, and the reach and return times.

    Parameters
    ----------
    metrics : dict
        The 1-DOF metrics of each label (positions in m, shown in mm).
    """
    result = Table(
        [
            "controller",
            "x(10 s) [mm]",
            "final x [mm]",
            "reach −150 mm ±5 mm at [s]",
            "back to 0 ±5 mm after 10 s [s]",
        ]
    )
    for name, m in metrics.items():
        at_10s = m["position_at_10s_m"]
        result.add(
            name,
            "n/a" if at_10s is None else number(1000 * at_10s, 1),
            number(1000 * m["final_position_m"], 1),
            number(m["reach_time_s"]),
            number(m["return_time_s"]),
        )
    return result


# The learned profiles' panels switch to a symmetric log scale when one learner's profile
# peaks more than this many times higher than another's (hlcmp_per_step's K_s reaches
# about 60 times hlcmp's): on a linear axis the smaller one would be a flat line at 0.
LOG_SCALE_SPREAD = 10.0


def _profile_panels(axes, runs: dict, names: list, colors: dict) -> None:
    """K_s on axes[0] [N/m], K_d on axes[1] [N·s/m], one line per learner in its colour."""
    panels = (("Ks", "stiffness $K_s$ [N/m]"), ("Kd", "damping $K_d$ [N·s/m]"))
    for axis, (key, ylabel) in zip(axes, panels):
        axis.set_ylabel(ylabel)
        if not names:
            axis.text(
                0.5,
                0.5,
                "no learning controller",
                ha="center",
                va="center",
                transform=axis.transAxes,
            )
            continue
        peaks = []
        for name in names:
            values = runs[name].series[key][:, 0]
            axis.plot(runs[name].t, values, color=colors[name], label=name)
            peaks.append(float(np.nanmax(np.abs(values), initial=0.0)))
        if min(peaks) > 0 and max(peaks) > LOG_SCALE_SPREAD * min(peaks):
            axis.set_yscale("symlog", linthresh=1.0)
            axis.set_ylabel(f"{ylabel}\n(symmetric log scale)")
    axes[0].set_title("learned profiles of the Hl-CMPs", fontsize=10)


def figures(runs: dict, scenario: Scenario) -> dict:
    """Fig. 13: position of every controller and the reference; the contact force; every
    learner's learned stiffness and damping, each on its own axis with its unit. A
    controller has one colour in every panel (its place in the scenario, as in the
    recording).

    Parameters
    ----------
    runs : dict of str to RunResult
        Every controller's run, by label.
    scenario : Scenario
        Its controllers' order sets the colours; its learners (the controller registry's
        `learners`) get the profile panels.

    Returns
    -------
    dict
        {"one_dof.png": the Figure}.
    """
    order = [*scenario.controllers, *(name for name in runs if name not in scenario.controllers)]
    colors = controller_colors(order)
    fig, axes = new_figure(4, 1, size=(8, 11), sharex=True)
    first = next(iter(runs.values()))
    axes[0].plot(first.t, first.series["xd"][:, 0], "k--", lw=1.2, label="reference $x_d$")
    for name, run in runs.items():
        axes[0].plot(run.t, run.series["x"][:, 0], color=colors[name], label=name)
        axes[1].plot(run.t, run.series["f_ext"][:, 0], color=colors[name], label=name)
    _profile_panels(axes[2:], runs, [n for n in learners(scenario) if n in runs], colors)
    axes[0].set_ylabel("position x [m]")
    axes[1].set_ylabel("environment force [N]")
    axes[3].set_xlabel("time [s]")
    axes[0].set_title("1-DOF comparison (paper Fig. 13): Hl-CMP vs. variable impedance [21]")
    for axis in axes:
        axis.grid(alpha=0.3)
    for axis in (axes[0], axes[2]):  # every controller above, the learners in their panels
        if axis.get_legend_handles_labels()[0]:
            axis.legend(fontsize=8, loc="best")
    return {"one_dof.png": fig}


EXPERIMENT = Experiment(
    name="one_dof",
    title="1-DOF comparison with a variable-impedance controller",
    paper_section="V-B",
    paper_figures="Fig. 13",
    world=SliderTask,
    controller_metrics=controller_metrics,
    claims=claims,
    table=table,
    figures=figures,
    task_done=reached_the_return,
)
