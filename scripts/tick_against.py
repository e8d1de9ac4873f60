"""This checkout's arm tick against another revision's `ControlTick`, side by side in one
process (docs/performance.md). The revision's systems/task_space.py, systems/arm.py,
systems/control_loop.py and core/operational_space.py are read with `git show` and imported
under other names; everything else is this checkout's. Compiled or numpy as HLCMP_KERNEL says.
The revision's side is always its generic `ControlTick`, which was the arm's tick until
10cc4e0; this checkout's arm tick is `FusedArmTick`. So against 10cc4e0 or later (main,
HEAD) it compares the generic tick with the fused one, not a tick with itself.

    python scripts/tick_against.py REV [--runs 3] [--insertion-s 3] [--rounds 5]

1. In the running insertion (fast path), every step evaluates both ticks on the same inputs,
   alternating which goes first, and applies this checkout's torque. The times compared are
   those of the tick that ran first after the plant's step, so both sides see the same
   moments of a shared machine's load.
2. At the logged states of a run of the insertion's Hl-CMP (θ' read, as `hlcmp bench`'s
   tick_paths evaluates them), call by call, alternating which goes first.

Prints each side's p50/p90/p99 [µs] and their ratios (REV / this checkout), the largest
relative difference of the torques (and θ'), and the load average.
"""

import argparse
import importlib
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from pydrake.multibody.plant import MultibodyPlant

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.core.dmp import phase_at
from hlcmp_drake.run.benchmark import advance
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.worlds import arm
from hlcmp_drake.worlds.models import load_models, scoped_frame

MODULES = {  # the revision's file -> the name it is imported under
    "hlcmp_drake/core/operational_space.py": "rev_operational_space",
    "hlcmp_drake/systems/task_space.py": "rev_task_space",
    "hlcmp_drake/systems/arm.py": "rev_arm",
    "hlcmp_drake/systems/control_loop.py": "rev_control_loop",
}


def revision_modules(rev: str, folder: Path) -> dict:
    """The revision's four modules, importing one another under their new names."""
    renames = {path[:-3].replace("/", "."): name for path, name in MODULES.items()}
    for path, name in MODULES.items():
        source = subprocess.run(
            ["git", "show", f"{rev}:{path}"], capture_output=True, text=True, check=True
        ).stdout
        for module, new_name in renames.items():
            source = source.replace(module, new_name)
        (folder / f"{name}.py").write_text(source)
    sys.path.insert(0, str(folder))
    return {name: importlib.import_module(name) for name in MODULES.values()}


def revision_tick(rev_modules, scenario, setup, plant, law, effort_limits):
    task = scenario.task
    tool = scoped_frame(plant, task.tool_frame)
    gains = (
        task.orientation_stiffness_Nm_per_rad,
        task.orientation_damping_Nms_per_rad,
        task.posture_stiffness_Nm_per_rad,
        task.posture_damping_Nms_per_rad,
    )
    return rev_modules["rev_control_loop"].ControlTick(
        rev_modules["rev_task_space"].TaskSpaceModel(plant, tool, axes=task.axes),
        rev_modules["rev_arm"].BelowTaskImpedance(
            plant, tool, setup.tool_orientation, setup.q0, *gains
        ),
        law,
        effort_limits,
    )


class BothTicks:
    """Stands in for the loop's tick: evaluates both, times them, applies this checkout's."""

    def __init__(self, ours, theirs, times):
        self.ours, self.theirs, self.times, self.calls, self.worst = ours, theirs, times, 0, 0.0

    def __getattr__(self, name):
        return getattr(self.ours, name)

    def evaluate(self, *args, **kwargs):
        order = [("rev", self.theirs), ("this", self.ours)][:: 1 if self.calls % 2 else -1]
        self.calls += 1
        results = {}
        for position, (side, tick) in enumerate(order):
            start = time.perf_counter()
            results[side] = tick.evaluate(*args, **kwargs)
            if position == 0:
                self.times[side].append(time.perf_counter() - start)
        self.worst = max(self.worst, difference(results["this"].torque, results["rev"].torque))
        return results["this"]


def difference(ours, theirs):
    return float(np.max(np.abs(ours - theirs)) / max(1.0, np.max(np.abs(theirs))))


def report(title, times, worst):
    print(title)
    for stat in (50, 90, 99):
        rev, this = (1e6 * np.percentile(times[side], stat) for side in ("rev", "this"))
        print(f"  p{stat}: rev {rev:6.1f} µs, this {this:6.1f} µs, rev / this {rev / this:.3f}")
    print(f"  largest relative difference of the outputs: {worst:.2g}")
    print(f"  load average (1, 5, 15 min): {tuple(round(x, 2) for x in os.getloadavg())}")


def in_the_running_insertion(rev_modules, duration, runs):
    scenario, _ = load_scenario("insertion", [f"duration_s={duration}"])
    short, _ = load_scenario("insertion", ["duration_s=0.05"])
    setup = arm.prepare(scenario)
    times: dict = {"rev": [], "this": []}
    worst = 0.0
    for run in range(runs + 1):  # the first, short, compiles: not kept
        this_scenario = scenario if run else short
        built = arm.build(this_scenario, "hlcmp", setup)
        loop = built.controller.system
        ours = loop._tick_of
        theirs = revision_tick(
            rev_modules, scenario, setup, ours.model.plant, ours.law, ours.effort_limits
        )
        loop._tick_of = both = BothTicks(ours, theirs, times if run else {"rev": [], "this": []})
        advance(built, this_scenario)
        worst = max(worst, both.worst)
    report(f"in the running insertion: {runs} runs of {duration} s", times, worst)


def at_logged_states(rev_modules, rounds):
    scenario, _ = load_scenario("insertion")
    setup = arm.prepare(scenario)
    run = simulate(arm.build(scenario, "hlcmp", setup), scenario, "hlcmp")
    xd = run.series["xd"]
    xd_dot = np.gradient(xd, run.t, axis=0)
    references = list(
        zip(
            xd,
            xd_dot,
            np.gradient(xd_dot, run.t, axis=0),
            phase_at(run.t, setup.dmp.tau, setup.dmp.settings.alpha_s)[:, None],
        )
    )
    ticks = {"this": arm.arm_tick(scenario, "hlcmp", plant=control_plant(scenario), setup=setup)}
    plant = control_plant(scenario)
    law = arm.arm_tick(scenario, "hlcmp", plant=plant, setup=setup).law
    ticks["rev"] = revision_tick(
        rev_modules, scenario, setup, plant, law, ticks["this"].effort_limits
    )
    theta = np.random.default_rng(0).uniform(0, 300, ticks["this"].law.theta_size)
    times: dict = {"rev": [], "this": []}
    worst = 0.0
    for round_ in range(rounds + 1):  # the first compiles: not kept
        for k, (state, reference) in enumerate(zip(run.series["plant_state"], references)):
            sides = ["rev", "this"][:: 1 if (k + round_) % 2 else -1]
            results = {}
            for side in sides:
                start = time.perf_counter()
                results[side] = result = ticks[side].evaluate(state, reference, theta)
                _ = result.law.rates
                if round_:
                    times[side].append(time.perf_counter() - start)
            worst = max(
                worst,
                difference(results["this"].torque, results["rev"].torque),
                difference(results["this"].law.rates, results["rev"].law.rates),
            )
    report(
        f"at the {len(references)} logged states of the insertion's Hl-CMP, {rounds} rounds",
        times,
        worst,
    )


def control_plant(scenario):
    """A control-side plant of the scenario's models, as `hlcmp serve`'s."""
    plant = MultibodyPlant(0.0)
    load_models(plant, scenario)
    return plant


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("rev", help="the git revision to compare with, e.g. main")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--insertion-s", type=float, default=3.0)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        rev_modules = revision_modules(args.rev, Path(folder))
        in_the_running_insertion(rev_modules, args.insertion_s, args.runs)
        at_logged_states(rev_modules, args.rounds)


if __name__ == "__main__":
    main()
