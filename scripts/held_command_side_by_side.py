"""The fast path's tick holding `held_command`'s torque and θ' against the same tick holding
`evaluate`'s (the whole result formed, as before `held_command`), side by side in one
process: two simulators per controller advance in alternating 0.1 s chunks, the order
swapped every chunk (docs/performance.md, "What the loop holds").

    python scripts/held_command_side_by_side.py one_dof 10 hlcmp_per_step,vic_fd_1.5
    python scripts/held_command_side_by_side.py insertion 3 hlcmp

Prints, per controller and side, µs per plant step and the tick's p50 and p99 (the
`ControlLoop`'s update, as `hlcmp bench`'s controller_tick_us), and the ratio of the
steps; the load average first and last.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.run.benchmark import advance_alternately, prepared_simulator
from hlcmp_drake.systems.control_loop import ControlLoop
from hlcmp_drake.worlds import common
from hlcmp_drake.worlds.build import diagram_factory

CHUNK_S = 0.1


class EvaluatingLoop(ControlLoop):
    """`ControlLoop` whose update holds the torque and θ' of the tick's whole result."""

    def _tick(self, context, state):
        if not self._result.is_out_of_date(context):  # a logged instant: as the loop does
            return super()._tick(context, state)
        start = time.perf_counter()
        state_now, reference, theta, now, force = self._inputs(context)
        result = self._tick_of.evaluate(state_now, reference, theta, time=now, external_force=force)
        state.get_mutable_discrete_state(self._torque_index).set_value(result.torque)
        if result.law.rates is not None:
            state.get_mutable_discrete_state(self._rate_index).set_value(result.law.rates)
        if self.tick_seconds is not None:
            self.tick_seconds.append(time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scenario")
    parser.add_argument("seconds", type=float)
    parser.add_argument("controllers", help="comma-separated labels")
    args = parser.parse_args()
    scenario, _ = load_scenario(
        args.scenario, [f"duration_s={args.seconds}", "task.control_path=fast"]
    )
    factory = diagram_factory(scenario)
    sides = {"evaluate": EvaluatingLoop, "held_command": ControlLoop}
    print(f"load average {os.getloadavg()[0]:.2f}")
    for controller in args.controllers.split(","):
        simulators, ticks = {}, {}
        for side, loop_class in sides.items():
            common.ControlLoop = loop_class  # what the world's builder adds
            built = factory(controller)
            ticks[side] = built.controller.system.record_tick_times()
            simulators[side] = prepared_simulator(built, scenario)
            simulators[side].Initialize()
        common.ControlLoop = ControlLoop
        spent = advance_alternately(simulators, args.seconds, CHUNK_S)
        steps = round(args.seconds / scenario.plant_config.time_step)
        for side in sides:
            micros = 1e6 * np.array(ticks[side])
            print(
                f"{controller} {side}: {spent[side] / steps * 1e6:.1f} µs a step, tick p50 "
                f"{np.percentile(micros, 50):.0f} p99 {np.percentile(micros, 99):.0f} µs"
            )
        print(
            f"{controller} evaluate / held_command: {spent['evaluate'] / spent['held_command']:.3f}"
        )
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
