"""The insertion experiment (paper Sec. V-D, Figs. 4-8) and claims C1-C4."""

import numpy as np

from hlcmp_drake.config.scenario import ArmTask, ControllerConfig, HlcmpConfig, Scenario
from hlcmp_drake.core.metrics import (force_smoothness, max_abs_force, mean_abs_force,
                                      mean_abs_position_error)
from hlcmp_drake.experiments.plots import bar_chart, new_figure
from hlcmp_drake.experiments.claims import constant_impedances, learner, smoother_force
from hlcmp_drake.experiments.experiment import Experiment
from hlcmp_drake.experiments.table import Table, number, per_axis
from hlcmp_drake.io.runs import RunResult

AXES = ("x", "y", "z")
CONTACT_FORCE_N = 0.5      # |f_ext| above this counts as contact
SELECTIVE_FRACTION = 0.2   # C3: x/y profiles within 20 % of the z profile's peak
CHANGE_FRACTION = 0.2      # C4: a rise or fall counts when it is 20 % of the profile's peak
PAPER_SAYS = {
    "C1": "higher constant stiffness gives smaller position error (Fig. 6)",
    "C2": "Hl-CMPs give a smoother contact force than constant stiffness (Fig. 8)",
    "C3": "only the task-relevant axis adapts: x/y stiffness and force stay near their start values (Fig. 4)",
    "C4": "feed-forward force and stiffness rise while pushing in and fall after the pierce; "
          "v ≈ ½ f_c (Fig. 4)",
}


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


def ff_to_commanded_ratio_z(run: RunResult) -> float | None:
    """The paper's observation u ~ v ~ f_c / 2 (Eq. 3: f_c = -(u + v)): mean v_z over mean
    (u_z + v_z), over the samples in contact. None without contact.

    Parameters
    ----------
    run : RunResult
        An Hl-CMP run, with the series "u", "v" and "f_ext" (T, 3) [N].
    """
    mask = contact_mask(run)
    if not mask.any():
        return None
    v, u = run.series["v"][mask, 2], run.series["u"][mask, 2]
    total = np.mean(u + v)
    return None if total == 0 else float(np.mean(v) / total)


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
    if isinstance(config, HlcmpConfig):
        metrics["max_stiffness_N_per_m"] = _per_axis(np.max(run.series["Ks"], axis=0))
        metrics["max_abs_feedforward_N"] = _per_axis(np.max(np.abs(run.series["v"]), axis=0))
        metrics["ff_to_commanded_force_ratio_z"] = ff_to_commanded_ratio_z(run)
    return metrics


def _phase_times(run):
    """(contact onset, pierce = peak |f_z| before the deepest point, end of the push =
    the deepest point of the reference) as sample indices; None without contact."""
    mask = contact_mask(run)
    if not mask.any():
        return None
    deepest = int(np.argmin(run.series["xd"][:, 2]))
    onset = int(np.argmax(mask))
    if onset >= deepest:
        return None
    pierce = onset + int(np.argmax(np.abs(run.series["f_ext"][onset:deepest + 1, 2])))
    return onset, pierce, deepest


def rise_and_fall(run: RunResult) -> dict | None:
    """C4 in numbers: K_s,z and v_z at contact onset, at the pierce and at the end of the
    push, and their peak in between. C4 holds when both rise from onset to pierce and
    fall from their peak to the end of the push by at least CHANGE_FRACTION of the peak.

    Parameters
    ----------
    run : RunResult
        An Hl-CMP run (series Ks, v, xd, f_ext).

    Returns
    -------
    dict or None
        The phase times [s] and the values [N/m, N]; None without a contact phase.
    """
    phases = _phase_times(run)
    if phases is None:
        return None
    onset, pierce, end = phases
    out = {"onset_s": float(run.t[onset]), "pierce_s": float(run.t[pierce]), "push_end_s": float(run.t[end])}
    for key, name in (("Ks", "stiffness"), ("v", "feedforward")):
        z = run.series[key][:, 2]
        out[name] = {"at_onset": float(z[onset]), "at_pierce": float(z[pierce]),
                     "peak": float(np.max(z[onset:end + 1])), "at_push_end": float(z[end])}
    return out


def claims(metrics: dict, scenario: Scenario, runs: dict | None = None) -> dict:
    """C1-C4 from {label: controller metrics}; the learner and the constant impedances
    are found by their config kind, the constants ordered by their configured stiffness.

    Parameters
    ----------
    metrics : dict
        Every controller's Figs. 6-8 metrics, by label.
    scenario : Scenario
        Whose configs say which label is the Hl-CMP and which are constant impedances.
    runs : dict of str to RunResult, optional
        Needed for C4, which reads the Hl-CMP's profiles over time.

    Returns
    -------
    dict
        C1 (always), and C2-C4 when there is a learner: {"holds", "evidence", "paper_says"}.
    """
    constants = constant_impedances(scenario)
    name = learner(scenario)
    hl = metrics.get(name)
    result = {}
    # C1: a stiffer constant impedance tracks better.
    errors = [sum(metrics[n]["mean_abs_position_error_m"].values()) for n in constants]
    result["C1"] = {
        "holds": all(a > b for a, b in zip(errors, errors[1:])),
        "evidence": "mean |x - x_d| summed over x, y, z: " + ", ".join(
            f"{n} {e * 1000:.2f} mm" for n, e in zip(constants, errors)) + ".",
    }
    if hl is None:
        result["C1"]["paper_says"] = PAPER_SAYS["C1"]
        return result
    # C2: the Hl-CMP's contact force is smoother than every constant impedance's (z axis).
    result["C2"] = smoother_force(metrics, name, constants, "sum |second difference of f_z|", PAPER_SAYS["C2"])
    # C3: only the task-relevant axis (z) adapts noticeably.
    k, v = hl["max_stiffness_N_per_m"], hl["max_abs_feedforward_N"]
    selective = all(k[a] <= SELECTIVE_FRACTION * k["z"] and v[a] <= SELECTIVE_FRACTION * v["z"]
                    for a in ("x", "y")) and k["z"] > 0
    result["C3"] = {
        "holds": bool(selective),
        "evidence": (f"peak learned stiffness x/y/z {k['x']:.1f}/{k['y']:.1f}/{k['z']:.1f} N/m, "
                     f"peak |feed-forward| x/y/z {v['x']:.2f}/{v['y']:.2f}/{v['z']:.2f} N "
                     f"(holds if x and y stay within {SELECTIVE_FRACTION:.0%} of z)."),
    }
    # C4: stiffness and feed-forward rise while pushing in and fall after the pierce.
    phases = rise_and_fall(runs[name]) if runs else None
    if phases is None:
        result["C4"] = {"holds": False, "evidence": "no contact phase found in the Hl-CMP run."}
    else:
        ok = all(p["peak"] > 0
                 and p["at_pierce"] - p["at_onset"] >= CHANGE_FRACTION * p["peak"]
                 and p["peak"] - p["at_push_end"] >= CHANGE_FRACTION * p["peak"]
                 for p in (phases["stiffness"], phases["feedforward"]))
        ks, ff = phases["stiffness"], phases["feedforward"]
        ratio = hl["ff_to_commanded_force_ratio_z"]
        result["C4"] = {
            "holds": bool(ok),
            "evidence": (f"K_s,z {ks['at_onset']:.1f} -> {ks['at_pierce']:.1f} (pierce, "
                         f"{phases['pierce_s']:.2f} s) -> peak {ks['peak']:.1f} -> {ks['at_push_end']:.1f} N/m "
                         f"at the end of the push; v_z {ff['at_onset']:.2f} -> {ff['at_pierce']:.2f} -> "
                         f"peak {ff['peak']:.2f} -> {ff['at_push_end']:.2f} N. Feed-forward / commanded "
                         f"force in z over the contact: "
                         f"{'n/a' if ratio is None else f'{ratio:.2f}'} (paper: about 0.5)."),
            "phases": phases,
        }
    for claim_name, claim in result.items():
        claim["paper_says"] = PAPER_SAYS[claim_name]
    return result


def table(metrics: dict) -> Table:
    """Per controller: the per-axis metrics of Figs. 6-8 and the peak z force.

    Parameters
    ----------
    metrics : dict
        {controller label: controller metrics}.
    """
    result = Table(["controller", "mean |e| x/y/z [mm]", "mean |f| x/y/z [N]", "smoothness x/y/z [N]",
                    "max |f_z| [N]"])
    for name, m in metrics.items():
        result.add(name, per_axis(m["mean_abs_position_error_m"], AXES, 1000),
                   per_axis(m["mean_abs_force_N"], AXES), per_axis(m["force_smoothness_N"], AXES, digits=1),
                   number(m["max_abs_force_N"]["z"]))
    return result


def figures(runs: dict, scenario: Scenario) -> dict:
    """Figs. 4-8.

    Parameters
    ----------
    runs : dict of str to RunResult
        By label; the learner's run draws Fig. 4.
    scenario : Scenario

    Returns
    -------
    dict of str to Figure
        fig4_profiles_z.png ... fig8_smoothness.png.
    """
    out = {}
    hl = runs.get(learner(scenario))
    if hl is not None:
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
        axes[4].plot(hl.t, hl.series["u"][:, 2] + hl.series["v"][:, 2], color="C1",
                     label="CF $u_z + v_z$ (Eq. 3)")
        axes[4].plot(hl.t, hl.series["v"][:, 2], color="C2", lw=1, label="FF $v_z$")
        axes[4].set_ylabel("force [N]")
        axes[4].set_xlabel("time [s]")
        axes[0].set_title("Hl-CMP profiles learned online in z (paper Fig. 4)")
        for axis in axes:
            axis.grid(alpha=0.3)
        axes[0].legend(fontsize=8)
        axes[4].legend(fontsize=8)
        out["fig4_profiles_z.png"] = fig

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

    metrics = {name: controller_metrics(run, scenario.controllers[name], scenario)
               for name, run in runs.items()}
    for file_name, key, label, scale in [
            ("fig6_position_error.png", "mean_abs_position_error_m", "mean |x - x_d| [mm] (paper Fig. 6)", 1000),
            ("fig7_mean_force.png", "mean_abs_force_N", "mean |f| [N] (paper Fig. 7)", 1),
            ("fig8_smoothness.png", "force_smoothness_N", "sum |second difference of f| [N] (paper Fig. 8)", 1)]:
        values = {name: [m[key][a] * scale for a in AXES] for name, m in metrics.items()}
        out[file_name] = bar_chart(values, AXES, label)
    return out


EXPERIMENT = Experiment(
    name="insertion", title="Insertion of a rod through a foam plank (iiwa14)",
    paper_section="V-D", paper_figures="Figs. 4-8",
    world=ArmTask, controller_metrics=controller_metrics, claims=claims, table=table, figures=figures)
