"""Two settings of one scenario's run, side by side in one process: the two simulators
advance in alternating chunks (0.1 simulated s each, the order swapped every chunk), so that
the machine's drift falls on both sides alike (docs/performance.md, "The slider's
integrator").

    python scripts/settings_side_by_side.py one_dof hlcmp_per_step \
        --a simulator_config.integration_scheme=runge_kutta3 \
            simulator_config.use_error_control=true simulator_config.accuracy=1e-4 \
        [--b SETTING ...] [--seconds 10]

Each side is the scenario with the fast path, `--seconds` and its own `--set`-style
settings (none: the scenario as it is), built with its harness (monitor, loggers) outside
the timing. Prints µs per plant step, the integrator's steps and derivative evaluations per
side, their ratio, and the load average first and last.
"""

from __future__ import annotations

import argparse
import os

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.run.benchmark import advance_alternately, prepared_simulator
from hlcmp_drake.worlds.build import diagram_factory

CHUNK_S = 0.1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenario")
    parser.add_argument("controller")
    parser.add_argument("--a", nargs="*", default=[], help="side a's settings")
    parser.add_argument("--b", nargs="*", default=[], help="side b's settings")
    parser.add_argument("--seconds", type=float, default=10.0)
    args = parser.parse_args()
    simulators, steps = {}, {}
    for side, settings in (("a", args.a), ("b", args.b)):
        scenario, _ = load_scenario(
            args.scenario, [f"duration_s={args.seconds}", "task.control_path=fast", *settings]
        )
        simulators[side] = prepared_simulator(diagram_factory(scenario)(args.controller), scenario)
        simulators[side].Initialize()
        steps[side] = round(args.seconds / scenario.plant_config.time_step)
    print(f"load average {os.getloadavg()[0]:.2f}")
    spent = advance_alternately(simulators, args.seconds, CHUNK_S)
    for side, simulator in simulators.items():
        integrator = simulator.get_integrator()
        print(
            f"{side}: {spent[side] / steps[side] * 1e6:6.1f} µs a plant step, "
            f"{integrator.get_num_steps_taken()} integrator steps, "
            f"{integrator.get_num_derivative_evaluations()} derivative evaluations"
        )
    print(f"a / b: {spent['a'] / spent['b']:.3f}")
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
