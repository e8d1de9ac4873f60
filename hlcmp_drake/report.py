"""Markdown for the README's results sections, generated from a run's metrics.json so
that no number in the README is typed by hand."""

import html
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


def claims_markdown(claims):
    rows = ["| claim | the paper says | we measured | reproduced |", "|---|---|---|---|"]
    for name, claim in claims.items():
        evidence = claim["evidence"].replace("|", "\\|")   # a literal bar inside a table cell
        rows.append(f"| {name} | {claim['paper_says']} | {evidence} | "
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


def cutting_markdown(metrics):
    return insertion_markdown(metrics)   # the same per-axis metrics and a claims table


RESULT_BLOCKS = {"one_dof": one_dof_markdown, "insertion": insertion_markdown, "cutting": cutting_markdown}


def learning_markdown(learn_metrics, replay_metrics=None):
    """The per-trial table of `hlcmp learn` (and a frozen replay's row, when given)."""
    rows = ["| run | mean abs(e), x+y+z [mm] | mean abs(f), x+y+z [N] | smoothness z [N] | effort [N] |",
            "|---|---|---|---|---|"]

    def row(label, r):
        return (f"| {label} | {1000 * sum(r['mean_abs_position_error_m'].values()):.2f} | "
                f"{sum(r['mean_abs_force_N'].values()):.2f} | {r['force_smoothness_N']['z']:.2f} | "
                f"{r['effort_N']:.2f} |")

    rows += [row(f"learn, trial {r['trial']}", r) for r in learn_metrics["trials"]]
    if replay_metrics is not None:
        rows.append(row("reproduce --freeze", replay_metrics["trials"][0]))
    better = learn_metrics["improves_over_trials"] or {}
    verdict = ", ".join(f"{key.replace('_', ' ')}: {'better' if ok else 'not better'}" for key, ok in better.items())
    return "\n".join(rows) + f"\n\nLast trial against the first -- {verdict}.\n"


def bench_markdown(results):
    """The benchmark's table (bench.json of `hlcmp bench`) with the targets of issue 6."""
    def met(ok):
        return "met" if ok else "**missed**"

    ratio = results.get("dmp_vs_movement_primitives")
    eval_us = results["controller_eval_us"]
    rows = ["| measure | value | target | |", "|---|---|---|---|",
            f"| insertion_rtf: simulated s per wall s, Hl-CMP insertion (9.5 s, no recording) | "
            f"{results['insertion_rtf']:.2f} | ≥ 2 | {met(results['insertion_rtf'] >= 2)} |",
            f"| controller_overhead_ratio: Hl-CMP run / same world driven by Drake's C++ "
            f"InverseDynamicsController along the same joint motion | {results['controller_overhead_ratio']:.2f} | "
            f"≤ 1.3 | {met(results['controller_overhead_ratio'] <= 1.3)} |"]
    for n, v in eval_us.items():
        target = "p99 ≤ 100" if n == "50" else ""
        verdict = met(v["p99"] <= 100) if n == "50" else ""
        rows.append(f"| controller_eval_us, N = {n}: derivatives + force output, median / p99 | "
                    f"{v['median']:.0f} / {v['p99']:.0f} µs | {target} | {verdict} |")
    rows += [f"| dmp_fit_ms: 3 axes, 2000 samples, N = 50 | {results['dmp_fit_ms']:.1f} ms | | |",
             f"| dmp_rollout_ms: the same DMP at 1 ms steps | {results['dmp_rollout_ms']:.1f} ms | | |",
             f"| dmp_vs_movement_primitives: our fit + rollout / movement_primitives 0.9.1's | "
             f"{'n/a' if ratio is None else f'{ratio:.2f}'} | ≤ 1.0 | "
             f"{'' if ratio is None else met(ratio <= 1.0)} |"]
    rows += [f"| wall time of `hlcmp run {name}` (all its controllers, figures, recording) | {wall:.1f} s | | |"
             for name, wall in results["scenario_wall_s"].items()]
    return "\n".join(rows) + "\n"


def claims_summary_markdown(all_metrics):
    """One row per claim per experiment: {scenario name: metrics} -> markdown table."""
    rows = ["| claim | experiment | the paper says | reproduced here |", "|---|---|---|---|"]
    for name, metrics in all_metrics.items():
        for claim_name, claim in metrics["claims"].items():
            rows.append(f"| {claim_name} | {name} | {claim['paper_says']} | "
                        f"**{'yes' if claim['holds'] else 'no'}** |")
    return "\n".join(rows) + "\n"


def update_readme(readme_path, run_dirs):
    """Rewrite the README's `<name> results` blocks, and the claims summary when every
    experiment is given, from {name: run folder}."""
    text = Path(readme_path).read_text()
    all_metrics = {name: json.loads((Path(run_dir) / "metrics.json").read_text())
                   for name, run_dir in run_dirs.items()}
    for name, metrics in all_metrics.items():
        text = replace_block(text, f"{name} results", RESULT_BLOCKS[name](metrics))
    if set(all_metrics) == set(RESULT_BLOCKS):
        text = replace_block(text, "claims summary", claims_summary_markdown(all_metrics))
    Path(readme_path).write_text(text)


def print_table_and_update(table, block, update, readme_path):
    """For the sweep scripts: print a generated table; with `update`, also write it into
    the README's `block`."""
    print(table)
    if update:
        text = Path(readme_path).read_text()
        Path(readme_path).write_text(replace_block(text, block, table))


# ----------------------------------------------------------------------------------------
# The offline report page (hlcmp report)
# ----------------------------------------------------------------------------------------

EXPERIMENT_TITLES = {
    "one_dof": ("1-DOF comparison with a variable-impedance controller", "Fig. 13"),
    "insertion": ("Insertion of a rod through a foam plank (iiwa14)", "Figs. 4-8"),
    "cutting": ("Cutting a soft block (iiwa14)", "Figs. 11-12"),
}

PAGE_STYLE = """
body { font-family: sans-serif; max-width: 1100px; margin: 2em auto; padding: 0 1em; color: #222; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.92em; }
th, td { border: 1px solid #bbb; padding: 0.3em 0.6em; vertical-align: top; text-align: left; }
th { background: #eee; }
td.yes { background: #dff3df; font-weight: bold; } td.no { background: #f8dcdc; font-weight: bold; }
img { max-width: 100%; border: 1px solid #ddd; margin: 0.5em 0; }
img.missing { border: 3px solid red; min-height: 2em; }
code { background: #f4f4f4; padding: 0 0.2em; }
"""


def _claims_html(claims):
    rows = ["<tr><th>claim</th><th>the paper says</th><th>we measured</th><th>reproduced</th></tr>"]
    for name, claim in claims.items():
        verdict = "yes" if claim["holds"] else "no"
        rows.append(f"<tr><td>{name}</td><td>{html.escape(claim['paper_says'])}</td>"
                    f"<td>{html.escape(claim['evidence'])}</td><td class='{verdict}'>{verdict}</td></tr>")
    return "<table>" + "".join(rows) + "</table>"


def _metrics_html(metrics):
    """Every controller's metrics as one table: a column per metric (per axis where it has axes)."""
    controllers = metrics["controllers"]
    columns = []   # (metric, axis or None), in first-seen order over all controllers
    for values in controllers.values():
        for key, value in values.items():
            for column in [(key, axis) for axis in value] if isinstance(value, dict) else [(key, None)]:
                if column not in columns:
                    columns.append(column)

    def cell(value):
        if isinstance(value, float):
            return f"{round(value, 9):.4g}"   # rounding shows a 1e-15 residue as 0
        return "–" if value is None else html.escape(str(value))

    head = "".join(f"<th>{html.escape(key)}{'' if axis is None else f' ({axis})'}</th>" for key, axis in columns)
    rows = [f"<tr><th>controller</th>{head}</tr>"]
    for name, values in controllers.items():
        cells = "".join(f"<td>{cell(values.get(key) if axis is None else values.get(key, {}).get(axis))}</td>"
                        for key, axis in columns)
        rows.append(f"<tr><td><code>{html.escape(name)}</code></td>{cells}</tr>")
    return "<div style='overflow-x: auto'><table>" + "".join(rows) + "</table></div>"


def report_page(out_dir, sections):
    """index.html text for `sections`: [(scenario name, its run folder, wall seconds)].
    Every link and image is relative to out_dir, so the page works offline."""
    out_dir = Path(out_dir)
    parts = ["<!DOCTYPE html><html><head><meta charset='utf-8'><title>hlcmp-drake: the paper's "
             f"experiments</title><style>{PAGE_STYLE}</style></head><body>",
             "<h1>Hl-CMPs on Drake: the paper's experiments, reproduced in simulation</h1>",
             "<p>Zeng et al., <i>An Approach for Robotic Learning Inspired by Biomimetic Adaptive "
             "Control</i>, IEEE TII 18(3), 2022. Every number below comes from the runs linked "
             "with it; each claim of the paper is marked reproduced or not.</p>",
             "<h2>Contents</h2><ul>"]
    parts += [f"<li><a href='#{name}'>{html.escape(EXPERIMENT_TITLES[name][0])}</a></li>" for name, _, _ in sections]
    parts.append("</ul>")
    for name, run_dir, seconds in sections:
        title, figures = EXPERIMENT_TITLES[name]
        metrics = json.loads((Path(run_dir) / "metrics.json").read_text())
        rel = Path(run_dir).resolve().relative_to(out_dir.resolve()).as_posix()
        parts.append(f"<h2 id='{name}'>{html.escape(title)} (paper {figures})</h2>")
        parts.append(f"<p>Status: <b>{metrics['status']}</b>; ran in {seconds:.0f} s. "
                     f"<a href='{rel}/recording.html'>3-D recording (offline)</a> · "
                     f"<a href='{rel}/metrics.json'>metrics.json</a> · "
                     f"<a href='{rel}/timeseries.npz'>timeseries.npz</a></p>")
        parts.append("<h3>Claims</h3>" + _claims_html(metrics.get("claims", {})))
        parts.append("<h3>Metrics</h3>" + _metrics_html(metrics))
        parts.append("<h3>Figures</h3>")
        for figure in sorted((Path(run_dir) / "figures").glob("*.png")):
            parts.append(f"<img src='{rel}/figures/{figure.name}' alt='{figure.stem}' "
                         "onerror=\"this.classList.add('missing')\">")
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"
