"""How much real-time jitter can move a served run's metrics, emulated without a clock:
the insertion's Hl-CMP served in lockstep by the project's driver with Drake's timing
(each command one plant step after its status: `--command-delay 1`), against the same
with each command 1 to 3 plant steps late at random and 1 % of the statuses reaching the
client only together with the next one (the client answers the newer, and the older
counts as missed), as on a busy machine in a run that is still "ok". Prints, per metric,
the largest change over the seeds: the basis of the real-time test's tolerance
(tests/test_run_drake_driver.py).

    python scripts/jitter_tolerance.py [--period 0.005] [--duration 3] [--seeds 5]
"""

import argparse
import random

from pydrake.lcm import DrakeLcm

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.experiments import experiment_of
from hlcmp_drake.run.runner import evaluate, without_claims
from hlcmp_drake.run.serve import TorqueClient, without_garbage_collection
from hlcmp_drake.run.sim_driver import SimulatedIiwaDriver
from hlcmp_drake.worlds.arm import prepare


def served(scenario, setup, rng, late_share, max_delay):
    """One lockstep run; with `rng`, commands 1..max_delay steps late and statuses held
    back with probability `late_share`. The metrics of the served controller."""
    lcm = DrakeLcm("memq://")
    client = TorqueClient(scenario, "hlcmp", lcm, setup=setup)
    driver = SimulatedIiwaDriver(scenario, lcm, setup, command_delay_steps=1)
    with without_garbage_collection():
        while not client.done:
            driver.publish_status()
            held_back = rng is not None and client.ticks > 0 and rng.random() < late_share
            if not held_back:
                lcm.HandleSubscriptions(0)
                client.poll()
                lcm.HandleSubscriptions(0)
            if driver.command is None or client.ticks == 0:
                continue  # the start guard
            if rng is not None:
                driver.command_delay_steps = rng.randint(1, max_delay)
            driver.step(driver.command[1])  # the latest command, as Drake's subscriber holds
    client.assess()
    run = client.run_result()
    metrics = evaluate({run.controller: run}, scenario, without_claims(experiment_of(scenario)))
    return client, metrics["controllers"]["hlcmp"]


def flat(metrics, prefix=""):
    out = {}
    for key, value in metrics.items():
        if isinstance(value, dict):
            out.update(flat(value, f"{prefix}{key}."))
        elif isinstance(value, float):
            out[prefix + key] = value
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--period", type=float, default=0.005)
    parser.add_argument("--duration", type=float, default=3.0)
    parser.add_argument("--seeds", type=int, default=5)
    args = parser.parse_args()
    scenario, _ = load_scenario(
        "insertion",
        [
            f"duration_s={args.duration}",
            f"iiwa_driver.period_s={args.period}",
            "iiwa_driver.force_source=external_torque",
        ],
    )
    setup = prepare(scenario)
    _, reference = served(scenario, setup, None, 0.0, 1)
    reference = flat(reference)
    largest = dict.fromkeys(reference, 0.0)
    for seed in range(args.seeds):
        client, metrics = served(scenario, setup, random.Random(seed), 0.01, 3)
        print(f"seed {seed}: {client.status}, {client.ticks} ticks, {client.missed_ticks} missed")
        for key, value in flat(metrics).items():
            largest[key] = max(largest[key], abs(value - reference[key]))
    print(f"\n| metric | lockstep | largest change over {args.seeds} seeds | relative |")
    print("|---|---|---|---|")
    for key, value in reference.items():
        relative = f"{largest[key] / abs(value):.1%}" if value else "-"
        print(f"| {key} | {value:.4g} | {largest[key]:.2g} | {relative} |")


if __name__ == "__main__":
    main()
