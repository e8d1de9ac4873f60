"""Where one Hl-CMP insertion run spends its time: cProfile of a 5 s run, top entries by
own time (the profile behind docs/performance.md).

    python scripts/profile_insertion.py [--seconds 5] [--top 15] [--path fast|modular]
"""

import argparse
import cProfile
import pstats

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.worlds.build import diagram_factory


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--top", type=int, default=15)
    parser.add_argument(
        "--path",
        choices=("fast", "modular"),
        default="fast",
        help="the control path (task.control_path)",
    )
    args = parser.parse_args()
    scenario, _ = load_scenario(
        "insertion", [f"duration_s={args.seconds}", f"task.control_path={args.path}"]
    )
    built = diagram_factory(scenario)("hlcmp")
    profile = cProfile.Profile()
    profile.enable()
    simulate(built, scenario, "hlcmp")
    profile.disable()
    pstats.Stats(profile).sort_stats("tottime").print_stats(args.top)


if __name__ == "__main__":
    main()
