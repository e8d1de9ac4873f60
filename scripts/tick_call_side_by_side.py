"""`ControlLoop`'s update calling the tick with its five arguments by position (and the
slider's tick slicing at offsets fixed when it is made) against the update as it was: the
arguments split into a tuple and a dict of keywords, `held_command` given them by keyword,
and the slice offsets worked out every tick. Side by side in one process: two simulators
per controller advance in alternating 0.1 s chunks, the order swapped every chunk
(docs/performance.md, "What the loop holds").

    python scripts/tick_call_side_by_side.py one_dof 10 hlcmp_per_step,hlcmp,vic_fd_1.5
    python scripts/tick_call_side_by_side.py insertion 2 hlcmp,const_500

Prints, per controller, µs per plant step on each side, their ratio, and whether the two
ended in the same state to the bit; the load average first and last.
"""

from __future__ import annotations

import argparse
import os
import time
import types

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.run.benchmark import (
    advance_alternately,
    ended_alike,
    prepared_simulator,
    side_by_side_line,
)
from hlcmp_drake.systems.control_loop import ControlLoop
from hlcmp_drake.systems.slider_tick import FusedSliderTick
from hlcmp_drake.worlds import common
from hlcmp_drake.worlds.build import diagram_factory

CHUNK_S = 0.1


class KeywordLoop(ControlLoop):
    """`ControlLoop` whose update gives the tick its time and force by keyword."""

    def _tick(self, context, state):
        if not self._result.is_out_of_date(context):  # a logged instant: as the loop does
            return super()._tick(context, state)
        start = time.perf_counter()
        arguments = (
            self.plant_state.Eval(context),
            tuple(port.Eval(context) for port in self._reference),
            self.theta.Eval(context) if self.theta is not None else None,
        )
        keywords = {
            "time": context.get_time(),
            "external_force": (
                self.external_force.Eval(context) if self.external_force is not None else None
            ),
        }
        torque, rates = self._tick_of.held_command(*arguments, **keywords)
        state.get_mutable_discrete_state(self._torque_index).set_value(torque)
        if rates is not None:
            state.get_mutable_discrete_state(self._rate_index).set_value(rates)
        if self.tick_seconds is not None:
            self.tick_seconds.append(time.perf_counter() - start)


def slices_every_tick(self, state, reference, theta, time, external_force):
    """`FusedSliderTick._torque_and_rates` with its offsets worked out every tick."""
    out = self._output(state, reference, theta, time, external_force)
    nv, m = self.model.nv, self.n_axes
    after = out[nv + 1 + m :]
    if self._kind == "hlcmp":
        return out[:nv], self.law._learning(lambda: after[6 * m :], theta)()
    if self._kind == "impedance":
        return out[:nv], None
    return out[:nv], after[m:]


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
    steps = round(args.seconds / scenario.plant_config.time_step)
    print(f"load average {os.getloadavg()[0]:.2f}")
    for controller in args.controllers.split(","):
        simulators = {}
        for side, loop_class in (("keywords", KeywordLoop), ("positional", ControlLoop)):
            common.ControlLoop = loop_class  # what the world's builder adds
            built = factory(controller)
            tick = built.controller.system._tick_of
            if side == "keywords" and isinstance(tick, FusedSliderTick):
                tick._torque_and_rates = types.MethodType(slices_every_tick, tick)
            simulators[side] = prepared_simulator(built, scenario)
            simulators[side].Initialize()
        common.ControlLoop = ControlLoop
        spent = advance_alternately(simulators, args.seconds, CHUNK_S)
        same = ended_alike(simulators)
        print(side_by_side_line(controller, spent, steps, ("keywords", "positional"), same))
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
