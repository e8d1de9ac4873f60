"""The controller's tick on its two paths, side by side in one process: numpy (the fallback)
and compiled by numba (`core.kernels`), in alternating rounds; ratios are medians of the
per-round ratios (docs/performance.md).

    python scripts/tick_paths.py [--rounds 3] [--insertion-s 3] [--one-dof-s 5]

Prints, per path: the insertion's Hl-CMP tick inside the running fast path (p50 / p99 µs)
and the run's RTF, and each 1-DOF controller's fast-path RTF; then how many times longer
the numpy path took (numpy's tick time / compiled's; for the RTF rows, compiled's RTF /
numpy's).
"""

import argparse
import os
import statistics
import time

import numpy as np

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.core.kernels import kernel_chosen
from hlcmp_drake.run.benchmark import advance
from hlcmp_drake.worlds import arm
from hlcmp_drake.worlds.build import diagram_factory

PATHS = ("numpy", "compiled")


def built_on(path, make):
    with kernel_chosen(path):
        return make()


def timed(built, scenario):
    start = time.perf_counter()
    advance(built, scenario)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--insertion-s", type=float, default=3.0)
    parser.add_argument("--one-dof-s", type=float, default=5.0)
    args = parser.parse_args()
    insertion, _ = load_scenario("insertion", [f"duration_s={args.insertion_s}"])
    setup = arm.prepare(insertion)
    one_dof, _ = load_scenario("one_dof", [f"duration_s={args.one_dof_s}"])
    sliders = diagram_factory(one_dof)
    labels = list(one_dof.controllers)
    warm_insertion, _ = load_scenario("insertion", ["duration_s=0.01"])
    warm_one_dof, _ = load_scenario("one_dof", ["duration_s=0.01"])
    warm_sliders = diagram_factory(warm_one_dof)
    for path in PATHS:  # compile (or load the cache) outside the timing
        advance(built_on(path, lambda: arm.build(warm_insertion, "hlcmp", setup)), warm_insertion)
        for label in labels:
            advance(built_on(path, lambda label=label: warm_sliders(label)), warm_one_dof)
    ticks: dict[str, list] = {path: [] for path in PATHS}
    walls: dict[str, dict[str, list]] = {
        path: {name: [] for name in ["insertion", *labels]} for path in PATHS
    }
    for _ in range(args.rounds):
        for path in PATHS:
            built = built_on(path, lambda: arm.build(insertion, "hlcmp", setup))
            times = built.controller.system.record_tick_times()
            walls[path]["insertion"].append(timed(built, insertion))
            ticks[path].append(np.array(times) * 1e6)
            for label in labels:
                built = built_on(path, lambda label=label: sliders(label))
                walls[path][label].append(timed(built, one_dof))
    print(f"load average (1 min) at the end: {os.getloadavg()[0]:.1f}")
    print("| | " + " | ".join(PATHS) + " | numpy's time / compiled's |\n|---|---|---|---|")
    for stat in (50, 99):
        values = {p: [np.percentile(t, stat) for t in ticks[p]] for p in PATHS}
        print(
            f"| insertion tick p{stat} [µs] | "
            + " | ".join(f"{statistics.median(values[p]):.0f}" for p in PATHS)
            + f" | {statistics.median(np.array(values['numpy']) / values['compiled']):.2f} |"
        )
    for name, seconds in [("insertion", args.insertion_s)] + [(x, args.one_dof_s) for x in labels]:
        rtf = {p: [seconds / w for w in walls[p][name]] for p in PATHS}
        print(
            f"| {name} RTF | "
            + " | ".join(f"{statistics.median(rtf[p]):.2f}" for p in PATHS)
            + f" | {statistics.median(np.array(rtf['compiled']) / rtf['numpy']):.2f} |"
        )


if __name__ == "__main__":
    main()
