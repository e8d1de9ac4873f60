"""Measure the served tick: `hlcmp sim-driver` and `hlcmp serve` as two processes over
udpm://...?ttl=0, as the README's "On a real iiwa" runs them, several times back to back;
print each run's serve.json numbers and a markdown table for the README.

    python scripts/serve_latency.py [--scenario insertion] [--runs 5] [--duration 3] [--realtime]

Each run uses its own multicast group and port, so runs never hear each other. Nothing else
should run on the machine meanwhile: the tick's time depends on it.
"""

import argparse
import json
import random
import subprocess
import sys
import tempfile
from pathlib import Path


def one_run(scenario: str, duration: float, realtime: bool, out: Path) -> dict:
    group = f"239.255.{random.randint(1, 254)}.{random.randint(1, 254)}"
    url = f"udpm://{group}:{random.randint(20000, 60000)}?ttl=0"
    cli = [sys.executable, "-m", "hlcmp_drake.cli"]
    driver = subprocess.Popen(
        [
            *cli,
            "sim-driver",
            scenario,
            "--lcm",
            url,
            "--quiet",
            *(["--realtime", "--duration", str(duration + 0.2)] if realtime else []),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    client = subprocess.run(
        [
            *cli,
            "serve",
            scenario,
            "--lcm",
            url,
            "--duration",
            str(duration),
            "--out",
            str(out),
            "--quiet",
        ],
        capture_output=True,
        text=True,
    )
    driver.communicate(timeout=120)
    if client.returncode != 0:
        sys.exit(f"serve failed: {client.stderr or client.stdout}")
    return json.loads((out / "serve.json").read_text())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", default="insertion")
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--duration", type=float, default=3.0)
    parser.add_argument(
        "--realtime", action="store_true", help="the driver paced to the wall clock"
    )
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for k in range(args.runs):
            record = one_run(args.scenario, args.duration, args.realtime, Path(folder) / f"run{k}")
            rows.append(record)
            ticks = record["tick_us"]
            print(
                f"run {k + 1}: {record['ticks']} ticks, {record['missed_ticks']} missed, "
                f"tick p50 {ticks['p50']:.0f} us, p99 {ticks['p99']:.0f} us, max "
                f"{ticks['max']:.0f} us",
                flush=True,
            )
    pacing = "real time" if args.realtime else "as fast as the client answers"
    print(
        f"\n| run ({args.scenario}, {args.duration:g} s, {pacing}) | ticks | missed | tick p50 | "
        "tick p99 | max |"
    )
    print("|---|---|---|---|---|---|")
    for k, record in enumerate(rows, 1):
        ticks = record["tick_us"]
        print(
            f"| {k} | {record['ticks']} | {record['missed_ticks']} | {ticks['p50']:.0f} µs | "
            f"{ticks['p99']:.0f} µs "
            f"| {ticks['max']:.0f} µs |"
        )


if __name__ == "__main__":
    main()
