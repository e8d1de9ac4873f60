"""Time one tick of the insertion's Hl-CMP (`FusedArmTick.evaluate`, at a fixed state) back to
back, and after what a served tick follows in practice: a sleep (waiting for a status), a
busy wait, one step of the world's simulation, or a pass over 32 MB (caches flushed).

    python scripts/tick_cold_warm.py [--samples 2000]

Prints a markdown table of p50 / p99 in microseconds (docs/iiwa.md).
"""

import argparse
import gc
import time

import numpy as np
from pydrake.lcm import DrakeLcm
from pydrake.multibody.plant import MultibodyPlant

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.run.sim_driver import SimulatedIiwaDriver
from hlcmp_drake.worlds.arm import arm_tick, prepare
from hlcmp_drake.worlds.models import load_models


def percentiles(tick, before, samples: int) -> tuple[float, float]:
    times = []
    for _ in range(samples):
        before()
        start = time.perf_counter()
        tick()
        times.append(time.perf_counter() - start)
    micros = np.array(times) * 1e6
    return float(np.percentile(micros, 50)), float(np.percentile(micros, 99))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=2000)
    args = parser.parse_args()
    scenario, _ = load_scenario("insertion")
    setup = prepare(scenario)
    plant = MultibodyPlant(0.0)
    load_models(plant, scenario)
    tick = arm_tick(scenario, "hlcmp", plant=plant, setup=setup)
    rng = np.random.default_rng(0)
    state = np.concatenate([setup.q0 + 0.01, rng.normal(0, 0.1, 7)])
    reference = (
        setup.dmp.start,
        np.array([0.0, 0.0, -0.03]),
        np.array([0.0, 0.0, 0.01]),
        np.array([0.5]),
    )
    theta = rng.uniform(0, 100, tick.law.theta_size)
    driver = SimulatedIiwaDriver(scenario, DrakeLcm("memq://"), setup)
    big = np.random.rand(4_000_000)

    def busy_wait():
        start = time.perf_counter()
        while time.perf_counter() - start < 0.0005:
            pass

    cases = {
        "back to back": lambda: None,
        "after a 0.5 ms sleep": lambda: time.sleep(0.0005),
        "after a 0.5 ms busy wait": busy_wait,
        "after one step of the world's simulation": lambda: driver.step(np.zeros(7)),
        "after touching 32 MB": big.sum,
    }
    gc.disable()
    tick.evaluate(state, reference, theta)  # the first call (the kernels' cache) is no sample
    print("| evaluate, at the same state | p50 | p99 |\n|---|---|---|")
    for name, before in cases.items():
        p50, p99 = percentiles(lambda: tick.evaluate(state, reference, theta), before, args.samples)
        print(f"| {name} | {p50:.0f} µs | {p99:.0f} µs |", flush=True)


if __name__ == "__main__":
    main()
