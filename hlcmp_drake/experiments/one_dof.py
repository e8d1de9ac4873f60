"""The 1-DOF comparison (paper Sec. V-B, Fig. 13) and claim C5."""

import numpy as np

from hlcmp_drake.metrics import settle_time, value_at

DEPTH_TOLERANCE_M = 0.005
PAPER_SAYS = {"C5": "Hl-CMPs reach the depth and return faster than [21]; [21] with an improper f_d "
                    "fails to reach it (0.5 N too shallow, 5 N too deep) (Fig. 13)"}


def _segments(scenario):
    """(target depth, its start time, return target, return start) from the steps."""
    times, positions = scenario.reference.times_s, scenario.reference.positions_m
    return positions[0][0], times[0], positions[1][0], times[1]


def controller_metrics(run, scenario):
    """position_at_10s_m, final_position_m, reach_time_s (absolute time), return_time_s
    (seconds after the return command at t = 10 s); None where never settled."""
    depth, t0, home, t_return = _segments(scenario)
    x = run.series["x"][:, 0]
    reach = settle_time(run.t, x, depth, DEPTH_TOLERANCE_M, t0, t_return)
    back = settle_time(run.t, x, home, DEPTH_TOLERANCE_M, t_return, scenario.duration_s + 1e-9)
    return {
        "position_at_10s_m": value_at(run.t, x, t_return),
        "final_position_m": float(x[-1]),
        "reach_time_s": reach,
        "return_time_s": None if back is None else back - t_return,
    }


def _fmt(value):
    return "never" if value is None else f"{value:.2f} s"


def _faster(a, b):
    """a strictly faster than b, where None means never."""
    return a is not None and (b is None or a < b)


def claims(metrics, scenario, runs=None):
    """C5: Hl-CMPs reach the desired depth and return faster than [21]; [21] with an
    improper f_d fails to reach the depth (0.5 N too shallow, 5 N too deep)."""
    depth = _segments(scenario)[0]
    hl = metrics["hlcmp"]
    vic = {name: m for name, m in metrics.items() if name.startswith("vic_fd_")}
    proper = min(vic, key=lambda n: abs(vic[n]["position_at_10s_m"] - depth))
    parts = {
        "hlcmp_reaches_depth": hl["reach_time_s"] is not None,
        "hlcmp_returns": hl["return_time_s"] is not None,
        "hlcmp_reaches_faster_than_best_vic": _faster(hl["reach_time_s"], vic[proper]["reach_time_s"]),
        "hlcmp_returns_faster_than_best_vic": _faster(hl["return_time_s"], vic[proper]["return_time_s"]),
        "vic_fd_0.5_too_shallow": vic["vic_fd_0.5"]["position_at_10s_m"] > depth + DEPTH_TOLERANCE_M,
        "vic_fd_5.0_too_deep": vic["vic_fd_5.0"]["position_at_10s_m"] < depth - DEPTH_TOLERANCE_M,
    }
    lines = [f"Hl-CMP: x(10 s) = {hl['position_at_10s_m']:.4f} m (target {depth} m), reach "
             f"{_fmt(hl['reach_time_s'])}, return {_fmt(hl['return_time_s'])} after t = 10 s."]
    for name, m in vic.items():
        lines.append(f"{name}: x(10 s) = {m['position_at_10s_m']:.4f} m, reach {_fmt(m['reach_time_s'])}, "
                     f"return {_fmt(m['return_time_s'])}.")
    lines.append(f"Best-placed [21] run: {proper}. Parts: "
                 + ", ".join(f"{k} = {'yes' if v else 'no'}" for k, v in parts.items()) + ".")
    return {"C5": {"holds": all(parts.values()), "paper_says": PAPER_SAYS["C5"], "parts": parts,
                   "evidence": " ".join(lines)}}


def table(metrics):
    rows = [f"{'controller':<12} {'x(10 s) [m]':>12} {'final [m]':>10} {'reach [s]':>10} {'return [s]':>11}"]
    for name, m in metrics.items():
        reach = "never" if m["reach_time_s"] is None else f"{m['reach_time_s']:.2f}"
        back = "never" if m["return_time_s"] is None else f"{m['return_time_s']:.2f}"
        rows.append(f"{name:<12} {m['position_at_10s_m']:>12.4f} {m['final_position_m']:>10.4f} "
                    f"{reach:>10} {back:>11}")
    return "\n".join(rows)


def figures(runs, scenario):
    """Fig. 13: position of every controller and the reference; the contact force; the
    Hl-CMP's learned stiffness and damping. Returns {file name: matplotlib figure}."""
    from hlcmp_drake.plots import new_figure

    fig, axes = new_figure(3, 1, size=(8, 8.5), sharex=True)
    first = next(iter(runs.values()))
    axes[0].plot(first.t, first.series["xd"][:, 0], "k--", lw=1.2, label="reference $x_d$")
    for name, run in runs.items():
        axes[0].plot(run.t, run.series["x"][:, 0], label=name)
        axes[1].plot(run.t, run.series["f_ext"][:, 0], label=name)
    hl = runs.get("hlcmp")
    if hl is not None:
        axes[2].plot(hl.t, hl.series["Ks"][:, 0], label="Hl-CMP stiffness $K_s$ [N/m]")
        axes[2].plot(hl.t, hl.series["Kd"][:, 0], label="Hl-CMP damping $K_d$ [Ns/m]")
    axes[0].set_ylabel("position x [m]")
    axes[1].set_ylabel("environment force [N]")
    axes[2].set_ylabel("learned profile")
    axes[2].set_xlabel("time [s]")
    axes[0].set_title("1-DOF comparison (paper Fig. 13): Hl-CMP vs. variable impedance [21]")
    for axis in axes:
        axis.grid(alpha=0.3)
        axis.legend(fontsize=8, loc="best")
    return {"one_dof.png": fig}
