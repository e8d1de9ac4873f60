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


def replace_block(text, name, body):
    """Replace the text between `<!-- BEGIN name -->` and `<!-- END name -->`."""
    begin, end = f"<!-- BEGIN {name} -->", f"<!-- END {name} -->"
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    return f"{head}{begin}\n{body}{end}{tail}"


def update_readme(readme_path, one_dof_dir):
    metrics = json.loads((Path(one_dof_dir) / "metrics.json").read_text())
    text = Path(readme_path).read_text()
    Path(readme_path).write_text(replace_block(text, "one_dof results", one_dof_markdown(metrics)))
