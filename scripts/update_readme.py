"""Regenerate the README's results sections and figures from fresh runs' outputs.

    hlcmp run one_dof --out out/one_dof && hlcmp run insertion --out out/insertion
    python scripts/update_readme.py [--runs out]
"""

import argparse
import shutil
from pathlib import Path

from hlcmp_drake.report import RESULT_BLOCKS, update_readme

ROOT = Path(__file__).resolve().parent.parent


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=Path, default=ROOT / "out", help="folder with one sub-folder per scenario")
    args = parser.parse_args()
    run_dirs = {name: args.runs / name for name in RESULT_BLOCKS if (args.runs / name / "metrics.json").exists()}
    update_readme(ROOT / "README.md", run_dirs)
    for name, run_dir in run_dirs.items():
        target = ROOT / "docs" / "figures" / name
        target.mkdir(parents=True, exist_ok=True)
        for figure in (run_dir / "figures").glob("*.png"):
            shutil.copy(figure, target / figure.name)
    print(f"README.md and docs/figures updated from {', '.join(map(str, run_dirs.values()))}")


if __name__ == "__main__":
    main()
