"""Where a step of the 1-DOF world's fast path goes: one controller's run, its parts taken
away one at a time, each the best of a few runs (docs/performance.md, "The slider's fast
path").

    python scripts/slider_step_parts.py [--controller vic_fd_1.5] [--seconds 5] [--runs 3]

Prints µs per 1 ms plant step for: the whole run (monitor, loggers, the spring, the tick);
without the loggers; without the safety monitor as well; with the tick's first result
reused instead of computed (no port evaluations, no law); and the plant alone, with and
without a C++ Integrator of θ's size beside it. Each line removes a piece from the one
above, so their differences are the pieces' costs. The load average comes first and last.
"""

from __future__ import annotations

import argparse
import os
import time
from unittest import mock

import numpy as np
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, Integrator

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.run.benchmark import advance
from hlcmp_drake.systems.control_loop import ControlLoop
from hlcmp_drake.worlds import slider
from hlcmp_drake.worlds.build import diagram_factory
from hlcmp_drake.worlds.models import add_plant


def the_world(scenario, controller: str):
    """A run of the scenario's fast-path diagram for `controller`, built outside the timing."""
    factory = diagram_factory(scenario)

    def run():
        built = factory(controller)
        return lambda: advance(built, scenario)

    return run


def plant_alone(scenario, theta_size: int | None):
    """The slider plant at zero actuation, with an Integrator of `theta_size` fed a
    constant (None: without), under the scenario's simulator config."""

    def run():
        builder = DiagramBuilder()
        plant, _ = add_plant(builder, scenario)
        builder.ExportInput(plant.get_actuation_input_port())
        if theta_size:
            integrator = builder.AddSystem(Integrator(theta_size))
            rate = builder.AddSystem(ConstantVectorSource(np.ones(theta_size)))
            builder.Connect(rate.get_output_port(), integrator.get_input_port())
        diagram = builder.Build()
        simulator = Simulator(diagram)
        diagram.get_input_port(0).FixValue(
            simulator.get_mutable_context(), np.zeros(plant.num_actuators())
        )
        ApplySimulatorConfig(scenario.simulator_config, simulator)
        simulator.Initialize()
        return lambda: simulator.AdvanceTo(scenario.duration_s)

    return run


def timed(make, steps: int, runs: int) -> float:
    """`per_step_us` of runs whose set-up (`make()`) stays outside the timing."""
    walls = []
    for _ in range(runs):
        go = make()
        start = time.perf_counter()
        go()
        walls.append(time.perf_counter() - start)
    return min(walls) / steps * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--controller", default="vic_fd_1.5")
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    scenario, _ = load_scenario("one_dof", [f"duration_s={args.seconds}", "task.control_path=fast"])
    steps = round(args.seconds / scenario.plant_config.time_step)
    print(f"load average {os.getloadavg()[0]:.2f}")
    warm, _ = load_scenario("one_dof", ["duration_s=0.2", "task.control_path=fast"])
    the_world(warm, args.controller)()()  # first calls (the kernels' cache) outside the timing
    lines = {"the whole run": timed(the_world(scenario, args.controller), steps, args.runs)}
    with mock.patch.object(slider, "add_loggers", lambda builder, scenario, ports: []):
        lines["without the loggers"] = timed(the_world(scenario, args.controller), steps, args.runs)
        with mock.patch.object(slider, "add_safety_monitor", lambda *a, **k: None):
            lines["... and without the safety monitor"] = timed(
                the_world(scenario, args.controller), steps, args.runs
            )
            ticked: set = set()
            tick = ControlLoop._tick

            def first_only(loop, context, state):
                # Later updates leave the state as it is: the first tick's torque and θ'
                # held, without reading a port or evaluating the law.
                if loop not in ticked:
                    ticked.add(loop)
                    tick(loop, context, state)

            with mock.patch.object(ControlLoop, "_tick", first_only):
                lines["... and the tick's first result reused"] = timed(
                    the_world(scenario, args.controller), steps, args.runs
                )
    theta_size = scenario.n_axes * 3  # the variable impedance's [x_c, x_c', Φ]
    lines[f"the plant and an Integrator({theta_size})"] = timed(
        plant_alone(scenario, theta_size), steps, args.runs
    )
    lines["the plant alone"] = timed(plant_alone(scenario, None), steps, args.runs)
    for what, us in lines.items():
        print(f"{what:45s} {us:7.1f} µs a step")
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
