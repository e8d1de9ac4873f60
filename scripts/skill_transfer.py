"""Does a skill library transfer to task parameters it never learned at? (issue 20, item 3)

    python scripts/skill_transfer.py --out out/skill_transfer [--workers 2]

Builds (or resumes) the two bundled insertion libraries -- Q read per second
(diagrams/libraries/insertion.yaml) and per control step (insertion_per_step.yaml) -- and
at each held-out query (HELD_OUT: between the grid's points, fixed before any result was
seen, never learned) learns the bundled demonstration for TRIALS trials from three starts:
theta = 0, the nearest library skill, and the regression (`hlcmp generalize`). Per start:
the first trial's mean tracking error (|x - x_d| summed over x, y, z), z force smoothness,
peak |f_z| and whether the tool went through the plank, and how many trials it takes to
reach the tracking error that TRIALS trials from theta = 0 reach. Writes OUT/transfer.json
and OUT/transfer.md (the table in docs/skills.md). Every run is a task of the local engine
(`--workers` processes); the libraries are resumable, the runs are not.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

# The held-out queries (depth of the tear [m], the torn hole's friction [N/m]): the
# midpoints of the grid's cells (depth 10 / 12.5 / 15 mm x friction 60 / 120 N/m),
# chosen with the grid, before anything was learned.
HELD_OUT = [(0.01125, 90.0), (0.01375, 90.0)]
TRIALS = 3
LIBRARIES = {"per second (Eq. 31)": "insertion", "per control step (Table I)": "insertion_per_step"}
STARTS = ("theta = 0", "nearest skill", "regression")
DEPTH, FRICTION = "task.puncture.depth_m", "task.puncture.hole_friction_N_per_m"


def query_of(point):
    return {DEPTH: point[0], FRICTION: point[1]}


def run_start(job: dict) -> dict:
    """Learn TRIALS trials at one held-out query from one start; the per-trial measures."""
    from hlcmp_drake.config.loading import load_scenario
    from hlcmp_drake.core.metrics import max_abs_force
    from hlcmp_drake.experiments.insertion import went_through
    from hlcmp_drake.io.paths import DIAGRAMS_DIR
    from hlcmp_drake.run.learning import learn
    from hlcmp_drake.run.skill_library import SkillLibrary

    library = SkillLibrary.load(job["library"])
    query = job["query"]
    overrides = library.overrides(query)
    skill, std = None, None
    if job["start"] != "theta = 0":
        method = "nearest" if job["start"] == "nearest skill" else "regression"
        skill, prediction, _ = library.generalize(query, method)
        if prediction.std is not None:
            std = {field: float(np.mean(values)) for field, values in prediction.std.items()}
    demo = DIAGRAMS_DIR / "demos" / "insertion_demo.csv"
    scenario_path = library.record["scenario_path"]
    result = learn(
        scenario_path, job["out"], demo=demo, skill=skill, trials=job["trials"], overrides=overrides
    )
    scenario, _ = load_scenario(scenario_path, overrides)
    trials = []
    for row, run in zip(result.metrics["trials"], result.runs):
        f_z = run.series["f_ext"][:, 2:3]
        trials.append(
            {
                "status": row["status"],
                "mean_abs_error_mm": 1000 * sum(row["mean_abs_position_error_m"].values()),
                "smoothness_z_N": row["force_smoothness_N"]["z"],
                "peak_f_z_N": float(max_abs_force(f_z)[0]),
                "through": bool(went_through(run, scenario)["done"]),
            }
        )
    return {**job, "trials_measured": trials, "mean_std": std}


def trials_to_reach(trials: list, target: float) -> int | None:
    """The first trial (1-based) whose tracking error is at most `target`, or None."""
    for k, trial in enumerate(trials, start=1):
        if trial["mean_abs_error_mm"] <= target:
            return k
    return None


def table(results: list) -> str:
    rows = [
        "| Q | held-out query: tear depth [mm], hole friction [N/m] | start | trial 1: mean "
        "\\|e\\| [mm] | smoothness z [N] | peak \\|f_z\\| [N] | through | trials to reach "
        f"{TRIALS} trials from θ = 0 (≤ ... mm) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for reading in LIBRARIES:
        for point in HELD_OUT:
            group = {
                r["start"]: r
                for r in results
                if r["reading"] == reading and r["point"] == list(point)
            }
            target = group["theta = 0"]["trials_measured"][-1]["mean_abs_error_mm"]
            for start in STARTS:
                trials = group[start]["trials_measured"]
                first = trials[0]
                reach = trials_to_reach(trials, target)
                rows.append(
                    f"| {reading} | {1000 * point[0]:.2f}, {point[1]:.0f} | {start} | "
                    f"{first['mean_abs_error_mm']:.2f} | {first['smoothness_z_N']:.2f} | "
                    f"{first['peak_f_z_N']:.2f} | {'yes' if first['through'] else 'no'} | "
                    f"{reach if reach else f'> {len(trials)}'} (≤ {target:.2f}) |"
                )
    return "\n".join(rows)


def main(argv=None) -> int:
    from hlcmp_drake.run.library import build_library
    from hlcmp_drake.run.sweep.engines import run_in_processes

    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="out/skill_transfer")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    args = parser.parse_args(argv)
    out = Path(args.out)
    start = time.perf_counter()
    jobs = []
    for reading, name in LIBRARIES.items():
        folder = out / "libraries" / name
        built = build_library(name, folder, workers=args.workers)
        print(
            f"library {name}: {len(built.record['skills'])} skills ({len(built.ran)} learned now)"
        )
        for point in HELD_OUT:
            for begin in STARTS:
                tag = f"depth={point[0]},friction={point[1]}"
                jobs.append(
                    {
                        "reading": reading,
                        "library": str(folder),
                        "point": list(point),
                        "query": query_of(point),
                        "start": begin,
                        "trials": TRIALS,
                        "out": str(out / "runs" / name / tag / begin.replace(" ", "_")),
                    }
                )
    results, failures = [], []

    def done(job, result, error):
        if error:
            failures.append(f"{job['reading']} {job['point']} {job['start']}: {error}")
        else:
            results.append(result)
            print(f"{job['reading']} {job['point']} {job['start']}: done", flush=True)

    run_in_processes(run_start, jobs, min(args.workers, len(jobs)), done)
    if failures:
        print("\n".join(failures), file=sys.stderr)
        return 1
    wall = time.perf_counter() - start
    load = subprocess.run(["uptime"], capture_output=True, text=True).stdout.strip()
    markdown = table(results)
    (out / "transfer.json").write_text(
        json.dumps(
            {
                "held_out": HELD_OUT,
                "trials": TRIALS,
                "wall_s": wall,
                "uptime": load,
                "results": results,
            },
            indent=2,
        )
        + "\n"
    )
    (out / "transfer.md").write_text(markdown + "\n")
    print(markdown)
    print(f"{wall:.0f} s; {load}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
