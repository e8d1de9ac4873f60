"""Measure the served tick against each simulated driver: `hlcmp serve` and a driver as
two processes over udpm://...?ttl=0, several times back to back; print each run's
serve.json numbers and a markdown table for the docs.

    python scripts/serve_latency.py [--scenario insertion] [--runs 3] [--duration 3]
        [--pairs lockstep,realtime,drake-5ms,drake-1ms] [--set iiwa_driver.busy_wait=false]
        [--set iiwa_driver.realtime_priority=50]

The pairs:

- lockstep: `hlcmp sim-driver` as fast as the client answers (it waits for every command);
- realtime: `hlcmp sim-driver --realtime`, a status every 1 ms whether answered or not;
- drake-5ms: Drake's own simulated driver as it is (`--drake-driver`, 5 ms);
- drake-1ms: Drake's driver systems behind a 1 ms publisher (`--status-period 0.001`).

Against Drake's driver the client reads the wrist force from the external torques (that
driver publishes no wrist sensor). Each run uses its own multicast group and port, so runs
never hear each other. Nothing else should run on the machine meanwhile: the tick's time,
and in real time the missed statuses, depend on it. So the machine's load average and plain
numpy's speed (`hlcmp bench`'s `machine_state`) are printed before the first run and after
the last.
"""

import argparse
import json
import random
import subprocess
import sys
import tempfile
from pathlib import Path

from hlcmp_drake.run.benchmark import machine_state

# pair -> (the driver's arguments, the client's settings, the status period [s])
PAIRS = {
    "lockstep": ([], [], 0.001),
    "realtime": (["--realtime"], [], 0.001),
    "drake-5ms": (
        ["--drake-driver"],
        ["iiwa_driver.period_s=0.005", "iiwa_driver.force_source=external_torque"],
        0.005,
    ),
    "drake-1ms": (
        ["--drake-driver", "--status-period", "0.001"],
        ["iiwa_driver.period_s=0.001", "iiwa_driver.force_source=external_torque"],
        0.001,
    ),
}


def one_run(scenario: str, pair: str, duration: float, out: Path, sets: list[str]) -> dict:
    """Serve `scenario` for `duration` s against the pair's driver, the client given the
    pair's settings and then `sets`; serve.json, with the client's exit code."""
    driver_args, client_sets, _ = PAIRS[pair]
    client_sets = [*client_sets, *sets]
    group = f"239.255.{random.randint(1, 254)}.{random.randint(1, 254)}"
    url = f"udpm://{group}:{random.randint(20000, 60000)}?ttl=0"
    cli = [sys.executable, "-m", "hlcmp_drake.cli"]
    # A real-time driver stops by itself once the client has been quiet for a second.
    driver = subprocess.Popen(
        [*cli, "sim-driver", scenario, "--lcm", url, "--quiet", *driver_args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    sets = [arg for key_value in client_sets for arg in ("--set", key_value)]
    client = subprocess.run(
        [*cli, "serve", scenario, "--lcm", url, "--duration", str(duration)]
        + ["--out", str(out), "--quiet", *sets],
        capture_output=True,
        text=True,
    )
    driver.communicate(timeout=120)
    if client.returncode not in (0, 3, 5):
        sys.exit(f"serve failed ({pair}): {client.stderr or client.stdout}")
    record = json.loads((out / "serve.json").read_text())
    record["exit_code"] = client.returncode
    return record


def row(pair: str, k: int, record: dict) -> str:
    """One markdown row: ticks, missed (and their share), tick p50/p99/max, the statuses
    that came during a warm-up (`iiwa_driver.warm_up_lead_s`), the status."""
    ticks, missed = record["ticks"], record["missed_ticks"]
    share = 100 * missed / (ticks + missed) if ticks + missed else 0.0
    us = record["tick_us"]
    timing = (
        f"{us['p50']:.0f} µs | {us['p99']:.0f} µs | {us['max']:.0f} µs"
        if us["p50"] is not None
        else "- | - | -"
    )
    overlaps = record["warm_up_overlaps"]
    return (
        f"| {pair} | {k} | {ticks} | {missed} ({share:.1f} %) | {timing} | {overlaps} | "
        f"{record['status']} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scenario", default="insertion")
    parser.add_argument("--runs", type=int, default=3, help="runs per pair")
    parser.add_argument("--duration", type=float, default=3.0, help="served seconds per run")
    parser.add_argument(
        "--pairs",
        default=",".join(PAIRS),
        help=f"comma-separated, of {', '.join(PAIRS)} (default all)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="a setting for every client, e.g. iiwa_driver.busy_wait=false",
    )
    args = parser.parse_args()
    pairs = args.pairs.split(",")
    unknown = [pair for pair in pairs if pair not in PAIRS]
    if unknown:
        parser.error(f"unknown pair {', '.join(unknown)}; the pairs are {', '.join(PAIRS)}")
    rows = []
    print(f"the machine before the runs: {machine_state()}", flush=True)
    with tempfile.TemporaryDirectory() as folder:
        for pair in pairs:
            for k in range(1, args.runs + 1):
                out = Path(folder) / f"{pair}{k}"
                record = one_run(args.scenario, pair, args.duration, out, args.set)
                rows.append(row(pair, k, record))
                print(
                    f"{pair} run {k}: {record['status']} (exit {record['exit_code']}), "
                    f"{record['stopped_because']}",
                    flush=True,
                )
                print(rows[-1], flush=True)
    print(
        f"\n| pair ({args.scenario}, {args.duration:g} s) | run | ticks | missed | tick p50 | "
        "tick p99 | max | warm-up overlaps | status |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    print(f"the machine after the runs: {machine_state()}")


if __name__ == "__main__":
    main()
