"""The first learning trial with and without the demonstration's force (docs/demo_force.md).

For the insertion and the cutting, under both readings of Q (per second, per control step),
one `hlcmp learn` trial of the bundled demonstration starting from theta = 0 and one
starting its feed-forward from the demonstration's force (`--demo-force`); the table puts
their tracking error, force smoothness, peak force and whether the task was done side by
side. Each trial's full output (metrics, figures, recording) is in OUT/TASK_READING_START/.

    python scripts/demo_force_table.py [--out out/demo_force]
"""

import argparse
from pathlib import Path

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.experiments import experiment_of
from hlcmp_drake.experiments.claims import learner
from hlcmp_drake.experiments.table import Table, number
from hlcmp_drake.io.outputs import write_json, write_text
from hlcmp_drake.io.paths import DIAGRAMS_DIR
from hlcmp_drake.present.tables import to_markdown
from hlcmp_drake.run.learning import learn

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
    """One learning trial: the row's measures, from the trial's own run."""
    overrides = [f"controllers.hlcmp.q_units={reading}"]
    result = learn(
        task,
        out / f"{task}_{reading}_{start}",
        demo=DIAGRAMS_DIR / "demos" / f"{task}_demo.csv",
        demo_force=start == "demo_force",
        overrides=overrides,
    )
    scenario, path = load_scenario(task, overrides)
    config = scenario.controllers[learner(scenario)]
    metrics = experiment_of(scenario, path).controller_metrics(result.runs[0], config, scenario)
    return {
        "task": task,
        "q_units": reading,
        "start": start,
        "status": result.metrics["status"],
        "mean_abs_position_error_m": metrics["mean_abs_position_error_m"],
        "force_smoothness_N": metrics["force_smoothness_N"],
        "max_abs_force_N": metrics["max_abs_force_N"],
        "task_done": metrics["task"]["done"],
    }


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


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/demo_force"))
    args = parser.parse_args()
    rows = [
        first_trial(task, reading, start, args.out)
        for task in TASKS
        for reading in READINGS
        for start in STARTS
    ]
    write_json(args.out / "demo_force.json", rows)
    markdown = to_markdown(table(rows), code_first_column=False)
    write_text(args.out / "demo_force.md", markdown)
    print(markdown, end="")


if __name__ == "__main__":
    main()
