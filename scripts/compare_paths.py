"""Compare two runs of one scenario, e.g. the fast and the modular control path:

    hlcmp run insertion --set task.control_path=modular --out out/paths/insertion-modular
    hlcmp run insertion --out out/paths/insertion-fast
    python scripts/compare_paths.py out/paths/insertion-modular out/paths/insertion-fast

Prints, per controller, the largest relative difference over its metrics (and which metric),
and whether every claim's verdict is the same.
"""

import argparse
import json
from pathlib import Path


def numbers(tree, path=""):
    """{dotted path: value} for every number in a metrics.json tree."""
    if isinstance(tree, dict):
        return {
            k: v
            for key, item in tree.items()
            for k, v in numbers(item, f"{path}.{key}" if path else key).items()
        }
    if isinstance(tree, list):
        return {
            k: v for i, item in enumerate(tree) for k, v in numbers(item, f"{path}[{i}]").items()
        }
    if isinstance(tree, (int, float)) and not isinstance(tree, bool):
        return {path: float(tree)}
    return {}


def verdicts(tree, path=""):
    """{dotted path: verdict} for every claim (its "holds" field)."""
    if isinstance(tree, dict):
        found = {path: tree["holds"]} if "holds" in tree else {}
        for key, item in tree.items():
            found.update(verdicts(item, f"{path}.{key}" if path else key))
        return found
    return {}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("first", type=Path, help="a run's output folder (metrics.json)")
    parser.add_argument("second", type=Path, help="the other run's output folder")
    args = parser.parse_args()
    first, second = (
        json.loads((folder / "metrics.json").read_text()) for folder in (args.first, args.second)
    )
    print("| controller | largest relative difference of its metrics | where |")
    print("|---|---|---|")
    for name, metrics in first["controllers"].items():
        a, b = numbers(metrics), numbers(second["controllers"][name])
        # relative to the metric's own size, ignoring values that are zero to rounding in both
        diffs = {
            key: abs(a[key] - b[key]) / max(abs(a[key]), abs(b[key]))
            for key in a
            if key in b and max(abs(a[key]), abs(b[key])) > 1e-9
        }
        worst = max(diffs, key=diffs.get)
        print(
            f"| {name} | {100 * diffs[worst]:.2f} % | {worst} ({a[worst]:.4g} vs {b[worst]:.4g}) |"
        )
    same = verdicts(first["claims"]) == verdicts(second["claims"])
    print(
        f"\nclaims' verdicts: {'the same' if same else 'DIFFERENT'} "
        f"({len(verdicts(first['claims']))} verdicts)"
    )


if __name__ == "__main__":
    main()
