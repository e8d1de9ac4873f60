"""Regenerate the README's results sections and figures from fresh runs' outputs.

    hlcmp report --out out/report
    hlcmp learn diagrams/demos/insertion_demo.csv --scenario insertion --trials 3 --out out/learn
    hlcmp reproduce out/learn/skill.npz --scenario insertion --freeze --out out/reproduce
    python scripts/update_readme.py --runs out/report --learn out/learn --reproduce out/reproduce
"""

import json

import argparse
import shutil
from pathlib import Path

from hlcmp_drake.report import RESULT_BLOCKS, learning_markdown, replace_block, update_readme

ROOT = Path(__file__).resolve().parent.parent


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=Path, default=ROOT / "out", help="folder with one sub-folder per scenario")
    parser.add_argument("--learn", type=Path, help="an `hlcmp learn` output folder")
    parser.add_argument("--reproduce", type=Path, help="an `hlcmp reproduce --freeze` output folder")
    args = parser.parse_args()
    if args.learn:
        learn = json.loads((args.learn / "metrics.json").read_text())
        replay = json.loads((args.reproduce / "metrics.json").read_text()) if args.reproduce else None
        readme = ROOT / "README.md"
        readme.write_text(replace_block(readme.read_text(), "learning results", learning_markdown(learn, replay)))
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
