"""The first learning trial with and without the demonstration's force (docs/demo_force.md).

For the insertion and the cutting, under both readings of Q (per second, per control step),
one `hlcmp learn` trial of the bundled demonstration starting from theta = 0 and one
starting its feed-forward from the demonstration's force (`--demo-force`); the table puts
their tracking error, force smoothness, peak force and whether the task was done side by
side. OUT/demo_force.md (the table), OUT/demo_force.json (its numbers), OUT/demo_force.png
(per task: the demonstrated force and the skill's encoding of it; the first trial's z
feed-forward and wrist force from either start, Q per second), and each trial's full
output (metrics, figures, recording) in OUT/TASK_READING_START/.

    python scripts/demo_force_table.py [--out out/demo_force]
"""

import argparse
from pathlib import Path

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.core.demo_force import feedforward_along
from hlcmp_drake.core.dmp import phase_at
from hlcmp_drake.experiments import experiment_of
from hlcmp_drake.experiments.claims import learner
from hlcmp_drake.experiments.plots import new_figure
from hlcmp_drake.experiments.table import Table, number
from hlcmp_drake.io.demos import read_demonstration
from hlcmp_drake.io.outputs import save_figure, write_json, write_text
from hlcmp_drake.io.paths import DIAGRAMS_DIR
from hlcmp_drake.io.skill import load_skill
from hlcmp_drake.present.tables import to_markdown
from hlcmp_drake.run.learning import learn
from hlcmp_drake.run.sweep.tasks import quiet_drake

TASKS = ("insertion", "cutting")
READINGS = {"per_second": "Q per second (Eq. 31)", "per_step": "Q per control step (Table I)"}
STARTS = {"zero": "theta = 0", "demo_force": "demonstration's force"}
HEADERS = [
    "task",
    "Q",
    "theta_v(t0)",
    "mean |e| x+y+z [mm]",
    "smoothness z [N]",
    "smoothness x+y+z [N]",
    "max |f_z| [N]",
    "task done",
]


def first_trial(task, reading, start, out):
    """One learning trial: (the row's measures, the trial's run, its output folder)."""
    overrides = [f"controllers.hlcmp.q_units={reading}"]
    folder = out / f"{task}_{reading}_{start}"
    result = learn(
        task,
        folder,
        demo=DIAGRAMS_DIR / "demos" / f"{task}_demo.csv",
        demo_force=start == "demo_force",
        overrides=overrides,
    )
    scenario, path = load_scenario(task, overrides)
    config = scenario.controllers[learner(scenario)]
    run = result.runs[0]
    metrics = experiment_of(scenario, path).metrics_of(run, config, scenario)
    row = {
        "task": task,
        "q_units": reading,
        "start": start,
        "status": result.metrics["status"],
        "mean_abs_position_error_m": metrics["mean_abs_position_error_m"],
        "force_smoothness_N": metrics["force_smoothness_N"],
        "max_abs_force_N": metrics["max_abs_force_N"],
        "task_done": metrics["task"]["done"],
    }
    return row, run, folder


def table(rows):
    """The rows as the Table of docs/demo_force.md."""
    out = Table(HEADERS)
    for row in rows:
        out.add(
            row["task"],
            READINGS[row["q_units"]],
            STARTS[row["start"]],
            number(1000 * sum(row["mean_abs_position_error_m"].values())),
            number(row["force_smoothness_N"]["z"]),
            number(sum(row["force_smoothness_N"].values())),
            number(row["max_abs_force_N"]["z"]),
            "yes" if row["task_done"] else "no",
        )
    return out


def figure(trials):
    """Per task: the demonstrated force against the skill's encoding of it (x, y, z), and
    the first trial's z feed-forward and wrist force from either start, Q per second."""
    fig, axes = new_figure(len(TASKS), 2, size=(13, 4 * len(TASKS)))
    for k, task in enumerate(TASKS):
        t, _, _, force = read_demonstration(
            DIAGRAMS_DIR / "demos" / f"{task}_demo.csv", with_force=True
        )
        skill = load_skill(trials[task, "per_second", "demo_force"][1] / "skill.npz")
        s = phase_at(t - t[0], skill.dmp.tau, skill.dmp.settings.alpha_s)
        encoded = feedforward_along(skill.demo_force, s, skill.dmp.settings)
        left, right = axes[2 * k], axes[2 * k + 1]
        for m, axis in enumerate("xyz"):
            left.plot(t, force[:, m], color=f"C{m}", alpha=0.5, label=f"demonstrated f_{axis}")
            left.plot(t, encoded[:, m], color=f"C{m}", ls="--", label=f"encoded f_{axis}")
        left.set_title(f"{task}: the demonstration's wrist force and its encoding")
        for n, start in enumerate(STARTS):
            run = trials[task, "per_second", start][0]
            right.plot(run.t, run.series["v"][:, 2], color=f"C{n}", label=f"v_z, {STARTS[start]}")
            right.plot(
                run.t,
                run.series["f_ext"][:, 2],
                color=f"C{n}",
                ls=":",
                label=f"f_z, {STARTS[start]}",
            )
        right.set_title(f"{task}: first trial, Q per second")
        for axis in (left, right):
            axis.set_xlabel("t [s]")
            axis.set_ylabel("[N]")
            axis.grid(alpha=0.3)
            axis.legend(fontsize=7)
    return fig


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("out/demo_force"))
    args = parser.parse_args()
    quiet_drake()  # each run's recording starts a Meshcat, whose INFO line is noise here
    trials = {}
    for task in TASKS:
        for reading in READINGS:
            for start in STARTS:
                row, run, folder = first_trial(task, reading, start, args.out)
                trials[task, reading, start] = (row, run, folder)
    rows = [row for row, _, _ in trials.values()]
    write_json(args.out / "demo_force.json", rows)
    save_figure(
        args.out / "demo_force.png",
        figure({key: (run, folder) for key, (_, run, folder) in trials.items()}),
    )
    markdown = to_markdown(table(rows), code_first_column=False)
    write_text(args.out / "demo_force.md", markdown)
    print(markdown, end="")


if __name__ == "__main__":
    main()
