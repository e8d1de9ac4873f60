"""What the arm's translational tick is made of: the whole tick (`ControlTick.evaluate`, the
insertion's Hl-CMP, compiled), its plant queries alone, and its compiled calls alone, each
timed in a loop at one state of a short insertion run (docs/performance.md, "Where the
floor is").

    python scripts/tick_floor.py [--calls 3000] [--rounds 3]

- the plant queries: the positions set once, the tool point's position, the spatial
  Jacobian, gravity, the mass matrix, the tool's orientation, and the two velocity
  settings with a bias term and a bias acceleration each (C_x x_e' by polarization): the
  calls the tick makes, in its order;
- the compiled calls: the six numba functions the tick calls (the operational-space
  terms, the sliding motion, the polarized Coriolis product, the Hl-CMP's force, the
  torque below the task and the saturated joint torque), with arrays of the tick's sizes.

What is left of the whole tick beyond the two is the Python between them. Prints µs per
call, the median of the rounds, and the load average.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import numpy as np
from pydrake.multibody.tree import JacobianWrtVariable

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.core.laws import HlcmpLaw
from hlcmp_drake.run.simulate import simulate
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


def a_running_tick() -> tuple[ControlTick, np.ndarray, tuple, np.ndarray]:
    """The insertion's Hl-CMP tick, its plant state 1.5 s into its run, a reference and θ."""
    scenario, _ = load_scenario("insertion", ["duration_s=1.5", "task.control_path=fast"])
    setup = arm.prepare(scenario)
    built = arm.build(scenario, "hlcmp", setup)
    run = simulate(built, scenario, "hlcmp")
    loop = built.controller.system
    tick = loop._tick_of
    assert isinstance(tick.law, HlcmpLaw), "the insertion's hlcmp is the Hl-CMP"
    context = loop.GetMyContextFromRoot(built.diagram.CreateDefaultContext())
    state = np.array(run.series["plant_state"][-1])
    reference = tuple(np.array(port.Eval(context)) for port in loop._reference)
    # weights of the size the run learns (as `hlcmp bench`'s tick_paths draws them)
    theta = np.random.default_rng(0).uniform(0, 300, tick.law.theta_size)
    return tick, state, reference, theta


def plant_queries(tick: ControlTick, state: np.ndarray):
    """The tick's plant queries in its order, at `state`, with a small velocity offset."""
    model = tick.model
    plant, context, frame = model.plant, model.context, model.frame
    world, point = plant.world_frame(), model._point
    nq, kv = model.nq, JacobianWrtVariable.kV
    offset = np.full(model.nv, 0.01)

    def queries():
        plant.SetPositions(context, state[:nq])
        plant.CalcPointsPositions(context, frame, point, world)
        plant.CalcJacobianSpatialVelocity(context, kv, frame, point, world, world)
        plant.CalcGravityGeneralizedForces(context)
        plant.CalcMassMatrix(context)
        frame.CalcRotationMatrixInWorld(context).matrix()
        for sign in (1.0, -1.0):
            plant.SetVelocities(context, state[nq:] + sign * offset)
            plant.CalcBiasTerm(context)
            plant.CalcBiasTranslationalAcceleration(context, kv, frame, point, world, world)

    return queries


def compiled_calls(tick: ControlTick, state: np.ndarray, theta: np.ndarray):
    """The tick's six compiled calls on arrays of its sizes (values that keep them finite)."""
    model, law, below = tick.model, tick.law, tick.below_task
    nv, m = model.nv, model.n_axes
    q, v = state[:nv], state[nv:]
    mass, jacobian = np.eye(nv), np.ascontiguousarray(np.eye(nv)[:m])
    vector, gains = np.full(m, 0.1), law.gains

    def calls():
        inertia, jbar, gravity, null_space = model._operational_space_terms(mass, jacobian, q)
        motion = law._motion(vector, vector, vector, vector, vector, gains.pi)
        coriolis = model._polarized_coriolis(jbar, inertia, v, v, vector, vector)
        out = law._force(
            motion, inertia, coriolis, gravity, gains.gain_l, 0.5, theta, law.centers, law.widths
        )
        held = below._below_task_torque(
            null_space,
            q,
            np.ascontiguousarray(np.eye(nv)[3:6]),
            np.eye(3),
            below._R_desired_inverse,
            q,
            v,
            below._q0,
            below._k_o,
            below._d_o,
            below._k_p,
            below._d_p,
        )
        tick._task_joint_torque(jacobian, out[:m], held, tick.effort_limits)

    return calls


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=3000)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    tick, state, reference, theta = a_running_tick()
    print(f"load average {os.getloadavg()[0]:.2f}; the tick's kernel path: {tick.kernel}")
    lines = {
        "the whole tick": lambda: tick.evaluate(state, reference, theta),
        "its plant queries alone": plant_queries(tick, state),
        "its six compiled calls alone": compiled_calls(tick, state, theta),
    }
    for what, function in lines.items():
        print(f"{what:32s} {per_call_us(function, args.calls, args.rounds):7.1f} µs")
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
