"""A scenario's models parsed into a plant both ways, side by side in one process: Drake's
ProcessModelDirectives of every directive, and `process_directives` (the bundled models
from their text), alternating, the order swapped every round (docs/performance.md,
"Parsing the models").

    python scripts/parse_side_by_side.py [SCENARIO ...] [--rounds 20]

Each try builds a MultibodyPlant with its SceneGraph from the scenario's plant config,
processes the directives and finalizes the plant, as a world and the checks at load do.
Prints the median ms per try of each way and their ratio, per scenario, and the load
average first and last.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from pydrake.multibody.plant import AddMultibodyPlant
from pydrake.systems.framework import DiagramBuilder

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.config.models import process_directives
from hlcmp_drake.io.paths import bundled_scenarios


def parse_ms(scenario, by_drake: bool) -> float:
    start = time.perf_counter()
    plant, scene_graph = AddMultibodyPlant(scenario.plant_config, DiagramBuilder())
    process_directives(plant, scenario.directives, scene_graph, by_drake)
    plant.Finalize()
    return 1e3 * (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenarios", nargs="*", default=bundled_scenarios())
    parser.add_argument("--rounds", type=int, default=20)
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f}")
    for name in args.scenarios:
        scenario, _ = load_scenario(name)
        times: dict[bool, list] = {True: [], False: []}
        for k in range(args.rounds):
            for by_drake in (True, False) if k % 2 else (False, True):
                times[by_drake].append(parse_ms(scenario, by_drake))
        drake, here = (statistics.median(times[side]) for side in (True, False))
        print(
            f"{name:12s} by Drake {drake:7.1f} ms  from text {here:6.1f} ms  "
            f"ratio {drake / here:5.1f}"
        )
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
