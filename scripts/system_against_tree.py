"""One of this checkout's systems against the same system of another checkout (e.g. a
worktree of an earlier commit), side by side in one process: the other's module is loaded
under another name and its class (or the function that adds it) put in the worlds in place
of this one's; everything else is this checkout's. Two simulators per controller advance in
alternating 0.1 s chunks, the order swapped every chunk (docs/performance.md: "Tried and
dropped: one port, one state" for the fast path's `ControlLoop`, "What was cut, and what
was tried" for the foam's `HoleFriction`, "One logger" for the loggers).

    git worktree add /tmp/old 3633177
    python scripts/system_against_tree.py control_loop /tmp/old one_dof 10 hlcmp,vic_fd_1.5
    python scripts/system_against_tree.py hole_friction /tmp/newer insertion 3 const_2000
    python scripts/system_against_tree.py loggers /tmp/old one_dof 10 hlcmp_per_step

Prints, per controller, µs per plant step on each side, their ratio, and whether the two
ended in the same state to the bit; the load average first and last. The other checkout's
class is made with this checkout's arguments, so it must take the same ones: `HoleFriction`
took two fewer before cf0ee4e (the face's extent), so compare it with a checkout from then
on (/tmp/newer above) (the measurements the docs quote were made when the two agreed).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
from pathlib import Path

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.run.benchmark import (
    advance_alternately,
    ended_alike,
    prepared_simulator,
    side_by_side_line,
)
from hlcmp_drake.worlds import arm, common, slider
from hlcmp_drake.worlds import puncture as foam
from hlcmp_drake.worlds.build import diagram_factory

CHUNK_S = 0.1

# name -> (its module's file in a checkout, its class or function, the world modules that
# use it)
SYSTEMS = {
    "control_loop": ("hlcmp_drake/systems/control_loop.py", "ControlLoop", (common,)),
    "hole_friction": ("hlcmp_drake/systems/puncture.py", "HoleFriction", (foam,)),
    "loggers": ("hlcmp_drake/worlds/common.py", "add_loggers", (slider, arm)),
}


def other_class(checkout: Path, file: str, name: str) -> type:
    """Class (or function) `name` of the module `file` in the checkout at `checkout`,
    loaded as the module "other_<name>"."""
    spec = importlib.util.spec_from_file_location(f"other_{name}", checkout / file)
    assert spec is not None and spec.loader is not None, checkout / file
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return getattr(module, name)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("system", choices=SYSTEMS)
    parser.add_argument("other", type=Path, help="the other checkout's folder")
    parser.add_argument("scenario")
    parser.add_argument("seconds", type=float)
    parser.add_argument("controllers", help="comma-separated labels")
    args = parser.parse_args()
    file, name, worlds = SYSTEMS[args.system]
    this = getattr(worlds[0], name)
    sides = {"other": other_class(args.other, file, name), "this": this}
    scenario, _ = load_scenario(
        args.scenario, [f"duration_s={args.seconds}", "task.control_path=fast"]
    )
    factory = diagram_factory(scenario)
    steps = round(args.seconds / scenario.plant_config.time_step)
    print(f"load average {os.getloadavg()[0]:.2f}")
    for controller in args.controllers.split(","):
        simulators = {}
        for side, system_class in sides.items():
            for world in worlds:  # what the world's builder adds
                setattr(world, name, system_class)
            try:
                built = factory(controller)
            except TypeError as error:  # a constructor of another signature
                sys.exit(f"{args.other}'s {name} takes other arguments than this one's: {error}")
            simulators[side] = prepared_simulator(built, scenario)
            simulators[side].Initialize()
        for world in worlds:
            setattr(world, name, this)
        spent = advance_alternately(simulators, args.seconds, CHUNK_S)
        same = ended_alike(simulators)
        print(side_by_side_line(controller, spent, steps, ("other", "this"), same))
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
