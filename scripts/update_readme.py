"""Regenerate the README's results sections and figures from fresh runs' outputs.

    hlcmp run one_dof --out out/one_dof
    python scripts/update_readme.py --one-dof out/one_dof
"""

import argparse
import shutil
from pathlib import Path

from hlcmp_drake.report import update_readme

ROOT = Path(__file__).resolve().parent.parent


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--one-dof", type=Path, default=ROOT / "out" / "one_dof")
    args = parser.parse_args()
    update_readme(ROOT / "README.md", args.one_dof)
    figures = ROOT / "docs" / "figures"
    figures.mkdir(parents=True, exist_ok=True)
    shutil.copy(args.one_dof / "figures" / "one_dof.png", figures / "one_dof.png")
    print(f"README.md and {figures} updated from {args.one_dof}")


if __name__ == "__main__":
    main()
