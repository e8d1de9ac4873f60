"""Regenerate the README's results sections and figures from fresh runs' outputs.

    hlcmp report --out out/report
    hlcmp learn diagrams/demos/insertion_demo.csv --scenario insertion --trials 3 --out out/learn
    hlcmp reproduce out/learn/skill.npz --scenario insertion --freeze --out out/reproduce
    hlcmp bench --out out/bench
    python scripts/update_readme.py --runs out/report --learn out/learn --reproduce out/reproduce \
        --bench out/bench
"""

import json

import argparse
import shutil
from pathlib import Path

from hlcmp_drake.report import (RESULT_BLOCKS, bench_markdown, learning_markdown, replace_block,
                                update_readme)

ROOT = Path(__file__).resolve().parent.parent


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=Path, default=ROOT / "out" / "report",
                        help="folder with one sub-folder per scenario (default out/report)")
    parser.add_argument("--learn", type=Path, help="an `hlcmp learn` output folder")
    parser.add_argument("--bench", type=Path, help="an `hlcmp bench` output folder (bench.json)")
    parser.add_argument("--reproduce", type=Path, help="an `hlcmp reproduce --freeze` output folder")
    args = parser.parse_args()
    if args.learn:
        learn = json.loads((args.learn / "metrics.json").read_text())
        replay = json.loads((args.reproduce / "metrics.json").read_text()) if args.reproduce else None
        readme = ROOT / "README.md"
        readme.write_text(replace_block(readme.read_text(), "learning results", learning_markdown(learn, replay)))
    if args.bench:
        table = bench_markdown(json.loads((args.bench / "bench.json").read_text()))
        for document in (ROOT / "README.md", ROOT / "docs" / "performance.md"):
            document.write_text(replace_block(document.read_text(), "benchmark", table))
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
