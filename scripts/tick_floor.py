"""What the arm's translational tick is made of: the whole tick (`FusedArmTick.evaluate`,
the insertion's Hl-CMP, compiled), the same tick through the laws' shared interface
(`ControlTick.evaluate`, about six compiled calls), its plant queries alone, and its two
compiled calls alone, each timed in a loop at one state of a short insertion run
(docs/performance.md, "Where the floor is").

    python scripts/tick_floor.py [--calls 3000] [--rounds 3]

- the plant queries: the positions set once, the tool point's position, the spatial
  Jacobian, gravity, the mass matrix, the tool's orientation, and the two velocity
  settings with a bias term and a bias acceleration each (C_x x_e' by polarization);
- the compiled calls: `core.arm_tick.arm_tick_start` and `hlcmp_arm_tick_finish` on the
  arguments the tick gives them.

What is left of the whole tick beyond the two is the Python between them. Prints µs per
call, the median of the rounds, and the load average.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.run.simulate import simulate
from hlcmp_drake.systems.arm_tick import FusedArmTick
from hlcmp_drake.systems.control_loop import ControlTick
from hlcmp_drake.worlds import arm


def per_call_us(function, calls: int, rounds: int) -> float:
    """The median over `rounds` of the mean time of `calls` calls of `function()` [µs]."""
    for _ in range(calls // 10):  # warm: caches, branch predictors
        function()
    means = []
    for _ in range(rounds):
        start = time.perf_counter()
        for _ in range(calls):
            function()
        means.append((time.perf_counter() - start) / calls * 1e6)
    return statistics.median(means)


def a_running_tick() -> tuple[FusedArmTick, np.ndarray, tuple, np.ndarray]:
    """The insertion's Hl-CMP tick, its plant state 1.5 s into its run, a reference and θ."""
    scenario, _ = load_scenario("insertion", ["duration_s=1.5", "task.control_path=fast"])
    setup = arm.prepare(scenario)
    built = arm.build(scenario, "hlcmp", setup)
    run = simulate(built, scenario, "hlcmp")
    loop = built.controller.system
    tick = loop._tick_of
    assert isinstance(tick, FusedArmTick), "the insertion's Hl-CMP tick is the fused one"
    context = loop.GetMyContextFromRoot(built.diagram.CreateDefaultContext())
    state = np.array(run.series["plant_state"][-1])
    reference = tuple(np.array(port.Eval(context)) for port in loop._reference)
    # weights of the size the run learns (as `hlcmp bench`'s tick_paths draws them)
    theta = np.random.default_rng(0).uniform(0, 300, tick.law.theta_size)
    return tick, state, reference, theta


def plant_queries(tick: FusedArmTick, state: np.ndarray):
    """The tick's plant queries, at `state`, with a small velocity offset: the position
    queries (`TaskSpaceModel.plant_queries`) and the two evaluations of the polarization
    (`TaskSpaceModel.biases`)."""
    model = tick.model
    velocities, offset = state[model.nq :], np.full(model.nv, 0.01)

    def queries():
        model.plant_queries(state)
        model.biases(velocities, offset)

    return queries


def compiled_calls(tick: FusedArmTick, state: np.ndarray, reference: tuple, theta: np.ndarray):
    """The tick's two compiled calls (`core.arm_tick`), on the arguments the tick gives them
    at `state`."""
    model = tick.model
    position, spatial, joint_gravity, mass, rotation = model.plant_queries(state)
    q, v = state[: model.nq], state[model.nq :]
    xd, xd_dot, xd_ddot, phase = reference
    row = tick._first_row
    start = tick._start(
        mass, spatial, row, joint_gravity, position, v, xd, xd_dot, xd_ddot, tick._pi
    )
    biases = model.biases(v, start[: model.nv])
    parameters = (*tick._law_parameters, *tick._held)

    def calls():
        tick._start(mass, spatial, row, joint_gravity, position, v, xd, xd_dot, xd_ddot, tick._pi)
        tick._finish(
            start,
            *biases,
            spatial,
            row,
            rotation,
            q,
            v,
            joint_gravity,
            phase[0],
            theta,
            *parameters,
        )

    return calls


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--calls", type=int, default=3000)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    tick, state, reference, theta = a_running_tick()
    shared = ControlTick(tick.model, tick.below_task, tick.law, tick.effort_limits)
    print(f"load average {os.getloadavg()[0]:.2f}; the tick's kernel path: {tick.kernel}")
    lines = {
        "the whole tick": lambda: tick.evaluate(state, reference, theta).law.rates,
        "through the shared interface": lambda: shared.evaluate(state, reference, theta).law.rates,
        "its plant queries alone": plant_queries(tick, state),
        "its two compiled calls alone": compiled_calls(tick, state, reference, theta),
    }
    for what, function in lines.items():
        print(f"{what:32s} {per_call_us(function, args.calls, args.rounds):7.1f} µs")
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
