"""Markdown for the README's results sections, generated from a run's metrics.json so
that no number in the README is typed by hand."""

import json
from pathlib import Path


def _seconds(value):
    return "never" if value is None else f"{value:.2f} s"


def one_dof_markdown(metrics):
    rows = ["| controller | x(10 s) [m] | final x [m] | reach −0.15 m ±5 mm at | back to 0 ±5 mm after t = 10 s |",
            "|---|---|---|---|---|"]
    for name, m in metrics["controllers"].items():
        rows.append(f"| `{name}` | {m['position_at_10s_m']:.4f} | {m['final_position_m']:.4f} | "
                    f"{_seconds(m['reach_time_s'])} | {_seconds(m['return_time_s'])} |")
    c5 = metrics["claims"]["C5"]
    parts = "\n".join(f"  - {name.replace('_', ' ')}: **{'yes' if ok else 'no'}**"
                      for name, ok in c5["parts"].items())
    verdict = "reproduced" if c5["holds"] else "not reproduced"
    return "\n".join(rows) + f"\n\n**C5: {verdict}.** Its parts:\n{parts}\n"


PAPER_SAYS = {
    "C1": "higher constant stiffness gives smaller position error (Fig. 6)",
    "C2": "Hl-CMPs give a smoother contact force than constant stiffness (Fig. 8)",
    "C3": "only the task-relevant axis adapts: x/y stiffness and force stay near their start values",
    "C4": "feed-forward force and stiffness rise while pushing in and fall after the pierce; v ≈ ½ f_c (Fig. 4)",
    "C5": "Hl-CMPs reach the depth and return faster than [21]; [21] with an improper f_d fails (Fig. 13)",
}


def claims_markdown(claims):
    rows = ["| claim | the paper says | we measured | reproduced |", "|---|---|---|---|"]
    for name, claim in claims.items():
        evidence = claim["evidence"].replace("|", "\\|")   # a literal bar inside a table cell
        rows.append(f"| {name} | {PAPER_SAYS[name]} | {evidence} | "
                    f"**{'yes' if claim['holds'] else 'no'}** |")
    return "\n".join(rows) + "\n"


def insertion_markdown(metrics):
    rows = ["| controller | mean abs(e) x/y/z [mm] | mean abs(f) x/y/z [N] | smoothness x/y/z [N] | max abs(f_z) [N] |",
            "|---|---|---|---|---|"]
    for name, m in metrics["controllers"].items():
        def triple(key, scale=1.0, fmt="{:.2f}"):
            return "/".join(fmt.format(m[key][a] * scale) for a in ("x", "y", "z"))
        rows.append(f"| `{name}` | {triple('mean_abs_position_error_m', 1000)} | {triple('mean_abs_force_N')} | "
                    f"{triple('force_smoothness_N', fmt='{:.1f}')} | {m['max_abs_force_N']['z']:.2f} |")
    return "\n".join(rows) + "\n\n" + claims_markdown(metrics["claims"])


def replace_block(text, name, body):
    """Replace the text between `<!-- BEGIN name -->` and `<!-- END name -->`."""
    begin, end = f"<!-- BEGIN {name} -->", f"<!-- END {name} -->"
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    return f"{head}{begin}\n{body}{end}{tail}"


RESULT_BLOCKS = {"one_dof": one_dof_markdown, "insertion": insertion_markdown}


def update_readme(readme_path, run_dirs):
    """Rewrite the README's `<name> results` blocks from {name: run folder}."""
    text = Path(readme_path).read_text()
    for name, run_dir in run_dirs.items():
        metrics = json.loads((Path(run_dir) / "metrics.json").read_text())
        text = replace_block(text, f"{name} results", RESULT_BLOCKS[name](metrics))
    Path(readme_path).write_text(text)


def print_table_and_update(table, block, update, readme_path):
    """For the sweep scripts: print a generated table; with `update`, also write it into
    the README's `block`."""
    print(table)
    if update:
        text = Path(readme_path).read_text()
        Path(readme_path).write_text(replace_block(text, block, table))
