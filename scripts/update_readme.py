"""Regenerate the README's results sections and figures from fresh runs' outputs.

    hlcmp report --out out/report --variants real_arm
    hlcmp learn diagrams/demos/insertion_demo.csv --scenario insertion --trials 3 --out out/learn
    hlcmp reproduce out/learn/skill.npz --scenario insertion --freeze --out out/reproduce
    hlcmp bench --out out/bench
    hlcmp sweep diagrams/sweeps/one_dof_sensitivity.yaml --out out/sweeps/one_dof_sensitivity
    hlcmp sweep diagrams/sweeps/insertion_learning_rate.yaml \
        --out out/sweeps/insertion_learning_rate
    python scripts/update_readme.py --runs out/report --learn out/learn --reproduce out/reproduce \
        --bench out/bench --sweeps out/sweeps
"""

import argparse
import json
import shutil
from pathlib import Path

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.experiments import EXPERIMENTS
from hlcmp_drake.present.report import robot_comparison, update_readme, write_block
from hlcmp_drake.present.sweep import sweep_table
from hlcmp_drake.present.tables import to_markdown
from hlcmp_drake.run.benchmark import table as bench_table
from hlcmp_drake.run.learning import trials_table
from hlcmp_drake.run.runner import scenario_record

ROOT = Path(__file__).resolve().parent.parent
# The README's blocks made from bundled sweeps: sweep file name (diagrams/sweeps/NAME.yaml,
# run into SWEEPS/NAME) -> block name.
# The variant whose runs `hlcmp report --variants real_arm` puts beside the perfect robot's.
ROBOT_VARIANT = "real_arm"
SWEEP_BLOCKS = {
    "one_dof_sensitivity": "one_dof sensitivity",
    "insertion_learning_rate": "insertion learning rate",
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--runs",
        type=Path,
        default=ROOT / "out" / "report",
        help="folder with one sub-folder per scenario (default out/report)",
    )
    parser.add_argument("--learn", type=Path, help="an `hlcmp learn` output folder")
    parser.add_argument("--bench", type=Path, help="an `hlcmp bench` output folder (bench.json)")
    parser.add_argument(
        "--reproduce", type=Path, help="an `hlcmp reproduce --freeze` output folder"
    )
    parser.add_argument(
        "--sweeps",
        type=Path,
        help="a folder with one `hlcmp sweep` output folder per bundled "
        f"sweep ({', '.join(SWEEP_BLOCKS)}); each found fills its block",
    )
    args = parser.parse_args()
    if args.sweeps:
        for name, block in SWEEP_BLOCKS.items():
            summary_path = args.sweeps / name / "sweep.json"
            if summary_path.exists():
                summary = json.loads(summary_path.read_text())
                if summary["counts"]["pending"] or summary["counts"]["error"]:
                    parser.error(
                        f"{summary_path}: the sweep is not finished (run it again to complete it)"
                    )
                write_block(
                    ROOT / "README.md",
                    block,
                    to_markdown(sweep_table(summary), code_first_column=False),
                )
    if args.learn:
        learn = json.loads((args.learn / "metrics.json").read_text())
        replay = (
            json.loads((args.reproduce / "metrics.json").read_text()) if args.reproduce else None
        )
        better = learn["improves_over_trials"] or {}
        verdict = ", ".join(
            f"{key.replace('_', ' ')}: {'better' if ok else 'not better'}"
            for key, ok in better.items()
        )
        write_block(
            ROOT / "README.md",
            "learning results",
            to_markdown(trials_table(learn, replay), code_first_column=False)
            + f"\nLast trial against the first -- {verdict}.\n",
        )
    if args.bench:
        table = to_markdown(
            bench_table(json.loads((args.bench / "bench.json").read_text())),
            code_first_column=False,
        )
        for document in (ROOT / "README.md", ROOT / "docs" / "performance.md"):
            write_block(document, "benchmark", table)
    run_dirs = {
        name: args.runs / name
        for name in EXPERIMENTS
        if (args.runs / name / "metrics.json").exists()
    }
    if not run_dirs and not (args.sweeps or args.learn or args.bench):
        parser.error(f"{args.runs}: no scenario folder with metrics.json in it")
    for name, run_dir in run_dirs.items():
        # The README's results are the bundled scenarios' as they are, not a shortened run's.
        record = run_dir / "scenario.yaml"
        if record.exists() and record.read_text() != scenario_record(load_scenario(name)[0]):
            parser.error(f"{record}: not the bundled {name} as it is (run with --set?)")
    update_readme(ROOT / "README.md", run_dirs)
    comparisons = []
    for name, run_dir in run_dirs.items():
        variant_metrics = args.runs / f"{name}_{ROBOT_VARIANT}" / "metrics.json"
        if variant_metrics.exists():
            metrics, claims = robot_comparison(
                json.loads((run_dir / "metrics.json").read_text()),
                json.loads(variant_metrics.read_text()),
                ROBOT_VARIANT,
                EXPERIMENTS[name],
            )
            claims_text = f"\n{to_markdown(claims, code_first_column=False)}" if claims.rows else ""
            comparisons.append(f"**{name}**\n\n{to_markdown(metrics)}{claims_text}")
    if comparisons:
        write_block(ROOT / "README.md", f"{ROBOT_VARIANT} comparison", "\n".join(comparisons))
    for name, run_dir in run_dirs.items():
        target = ROOT / "docs" / "figures" / name
        target.mkdir(parents=True, exist_ok=True)
        for figure in (run_dir / "figures").glob("*.png"):
            shutil.copy(figure, target / figure.name)
        if (run_dir / "probe" / "probe.png").exists():  # hlcmp report probes each arm world
            shutil.copy(run_dir / "probe" / "probe.png", target / "probe.png")
    print(f"README.md and docs/figures updated from {', '.join(map(str, run_dirs.values()))}")


if __name__ == "__main__":
    main()
