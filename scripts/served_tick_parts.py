"""Where a served tick's time goes: `hlcmp serve`'s client in this process against a
simulated driver in another (`hlcmp sim-driver --realtime` at 1 ms, or Drake's driver at
5 ms), over udpm on loopback, with its stages stamped for every answered status
(docs/performance.md, "The arm's tick in two compiled calls").

    python scripts/served_tick_parts.py [--pair realtime|drake-5ms] [--duration 3]

Stages, from the status's receipt (the LCM callback, where `tick_us` starts) to its
command's publication (where it ends): to the client's poll, the status read, the
answer's bookkeeping before the tick, the tick (`evaluate`), the bookkeeping after it
(the command, its checks and its encoding), and the publish call itself. Prints p50 and
p99 of each [µs], the served tick's, and the load average.
"""

from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
import time

import numpy as np

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.run import serve
from hlcmp_drake.run.runner import experiment_worlds
from hlcmp_drake.worlds.arm import prepare

PAIRS = {
    "realtime": (["--realtime"], []),
    "drake-5ms": (
        ["--drake-driver"],
        ["iiwa_driver.period_s=0.005", "iiwa_driver.force_source=external_torque"],
    ),
}
STAGES = ("received", "polled", "decoded", "tick_start", "tick_end", "publishing", "published")


class StampedLcm:
    """The client's LCM, stamping the publish call's start and end."""

    def __init__(self, lcm, stamps: dict):
        self._lcm, self._stamps = lcm, stamps

    def Publish(self, channel: str, data: bytes) -> None:  # noqa: N802 (DrakeLcm's name)
        self._stamps["publishing"] = time.perf_counter()
        self._lcm.Publish(channel, data)
        self._stamps["published"] = time.perf_counter()

    def __getattr__(self, name):
        return getattr(self._lcm, name)


def stamped_client(client: serve.TorqueClient, rows: list) -> None:
    """Wrap the client's poll, status reading, tick and publishing so that each answered status
    appends its stamps (in `STAGES` order) to `rows`."""
    stamps: dict = {}
    poll, evaluate, read = client.poll, client.tick.evaluate, serve.read_status_state

    def stamped_poll():
        stamps.clear()
        if client._latest is not None:
            stamps["received"], stamps["polled"] = client._latest[0], time.perf_counter()
        poll()
        if "published" in stamps and "tick_end" in stamps:
            rows.append([stamps[stage] for stage in STAGES])

    def stamped_read(*args):
        status = read(*args)
        stamps["decoded"] = time.perf_counter()
        return status

    def stamped_evaluate(*args, **kwargs):
        stamps["tick_start"] = time.perf_counter()
        result = evaluate(*args, **kwargs)
        stamps["tick_end"] = time.perf_counter()
        return result

    client.poll, client.tick.evaluate = stamped_poll, stamped_evaluate
    serve.read_status_state = stamped_read
    client._lcm = StampedLcm(client._lcm, stamps)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pair", choices=PAIRS, default="realtime")
    parser.add_argument("--duration", type=float, default=3.0)
    args = parser.parse_args()
    driver_args, client_sets = PAIRS[args.pair]
    group = f"239.255.{random.randint(1, 254)}.{random.randint(1, 254)}"
    url = f"udpm://{group}:{random.randint(20000, 60000)}?ttl=0"
    scenario, _ = load_scenario(
        "insertion", [f"duration_s={args.duration}", *client_sets], experiment_worlds()
    )
    scenario, controller, theta0 = serve.served_scenario(scenario, None, None, False)
    lcm = serve.open_lcm(url)
    client = serve.TorqueClient(scenario, controller, lcm, theta0, prepare(scenario))
    rows: list = []
    stamped_client(client, rows)
    print(f"load average {os.getloadavg()[0]:.2f}")
    driver = subprocess.Popen(
        [sys.executable, "-m", "hlcmp_drake.cli", "sim-driver", "insertion", "--lcm", url]
        + ["--quiet", *driver_args],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    serve.serve(client, lcm, url)
    driver.wait(timeout=120)
    print(
        f"{args.pair}: {client.ticks} ticks, {client.missed_ticks} missed, {client.status}; "
        f"{len(rows)} stamped"
    )
    stamps = 1e6 * np.array(rows)
    names = [
        "to the poll",
        "reading the status",
        "before the tick",
        "the tick (evaluate)",
        "after the tick",
        "the publish call",
    ]
    parts = [(name, stamps[:, k + 1] - stamps[:, k]) for k, name in enumerate(names)]
    for name, part in [*parts, ("the served tick", stamps[:, -1] - stamps[:, 0])]:
        p50, p99 = np.percentile(part, 50), np.percentile(part, 99)
        print(f"{name:22s} p50 {p50:6.0f}  p99 {p99:6.0f} µs")
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
