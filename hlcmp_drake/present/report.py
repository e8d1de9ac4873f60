"""The README's generated blocks and the offline report page, both made from runs'
metrics.json files (no number in the README is typed by hand), through the experiments
registry and the one Table model."""

from __future__ import annotations

import dataclasses as dc
import html
import json
from pathlib import Path

from hlcmp_drake.config.loading import load_scenario
from hlcmp_drake.experiments import EXPERIMENTS, Experiment, experiment_of
from hlcmp_drake.experiments.claims import (
    evidence_table,
    reading_label,
    verdict_text,
    verdicts_table,
)
from hlcmp_drake.experiments.table import Table
from hlcmp_drake.present.tables import to_html, to_markdown


def results_markdown(metrics: dict, experiment: Experiment) -> str:
    """A scenario's README block: its controllers' table and its claims table.

    Parameters
    ----------
    metrics : dict
        A run's metrics.json content.
    experiment : Experiment
        The experiment the scenario names.
    """
    learners = metrics.get("learners", {})
    text = to_markdown(experiment.table(metrics["controllers"]))
    if not any(metrics["claims"].values()):  # an experiment with no claims (yet)
        return text
    return (
        text
        + "\n"
        + to_markdown(verdicts_table(metrics["claims"], learners), code_first_column=False)
        + "\n"
        + to_markdown(evidence_table(metrics["claims"], learners), code_first_column=False)
    )


def claims_summary_table(all_metrics: dict) -> Table:
    """One row per claim per scenario, one verdict column per reading of Q.

    Parameters
    ----------
    all_metrics : dict
        {scenario name: its metrics.json content}, in the order of the rows.
    """
    readings = {}  # column header -> (learner label) in first-seen order
    for metrics in all_metrics.values():
        for name in metrics["claims"]:
            readings.setdefault(reading_label(name, metrics.get("learners", {})), None)
    headers = list(readings)
    table = Table(["claim", "experiment", "the paper says"] + headers)
    for scenario, metrics in all_metrics.items():
        rows = {}
        for name, by_claim in metrics["claims"].items():
            column = reading_label(name, metrics.get("learners", {}))
            for claim_name, claim in by_claim.items():
                rows.setdefault(claim_name, {"paper_says": claim["paper_says"]})[column] = claim[
                    "holds"
                ]
        for claim_name, row in rows.items():
            table.add(
                claim_name,
                scenario,
                row["paper_says"],
                *("–" if h not in row else f"**{verdict_text(row[h])}**" for h in headers),
            )
    return table


def replace_block(text: str, name: str, body: str) -> str:
    """Replace the text between `<!-- BEGIN name -->` and `<!-- END name -->`.

    Parameters
    ----------
    text : str
        The document.
    name : str
        The block's name.
    body : str
        The new content (ending with a newline).
    """
    begin, end = f"<!-- BEGIN {name} -->", f"<!-- END {name} -->"
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    return f"{head}{begin}\n{body}{end}{tail}"


def update_readme(readme_path: Path, run_dirs: dict) -> None:
    """Rewrite the README's `<name> results` blocks, and the claims summary (the paper's
    claims) when every experiment of the paper is given.

    Parameters
    ----------
    readme_path : Path
    run_dirs : dict of str to Path
        {bundled scenario name: its run folder}; each bundled scenario is named after its
        experiment.
    """
    text = Path(readme_path).read_text()
    all_metrics = {
        name: json.loads((Path(run_dir) / "metrics.json").read_text())
        for name, run_dir in run_dirs.items()
    }
    for name, metrics in all_metrics.items():
        experiment = experiment_of(load_scenario(name)[0])
        text = replace_block(text, f"{name} results", results_markdown(metrics, experiment))
    paper = [name for name, experiment in EXPERIMENTS.items() if experiment.from_paper]
    if set(paper) <= set(all_metrics):
        ordered = {name: all_metrics[name] for name in paper}
        text = replace_block(
            text,
            "claims summary",
            to_markdown(claims_summary_table(ordered), code_first_column=False),
        )
    Path(readme_path).write_text(text)


def write_block(readme_path: Path, block: str, body: str) -> None:
    """Write `body` into a document's generated `block` (sweep scripts, benchmark).

    Parameters
    ----------
    readme_path : Path
        The document (README.md, docs/performance.md).
    block : str
        The block's name.
    body : str
        Its new content.
    """
    text = Path(readme_path).read_text()
    Path(readme_path).write_text(replace_block(text, block, body))


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


# Where a run was unstable: its claims and figures compare every controller's whole run
# (`runner.evaluate` judges none, `write_scenario` draws none), so the page shows neither.
UNSTABLE_NOTE = (
    "<p>Not judged, and no figures: a run stopped unstable (see the status above), and the "
    "claims and figures compare every controller's whole run.</p>"
)


@dc.dataclass
class ReportSection:
    """One scenario's part of the report: its name, run folder, wall time [s], the
    experiment that evaluated it, the folder of its world's probe (None: no probe) and
    the folders of its runs under variants ({variant name: folder}; e.g. a real arm's),
    and what each variant changes ({variant name: the dotted keys whose values differ from
    the scenario's without it, `config.variants.changed_keys`}; a variant missing here is
    shown without saying what it changes)."""

    name: str
    run_dir: Path
    wall_s: float
    experiment: Experiment
    probe_dir: Path | None = None
    variants: dict = dc.field(default_factory=dict)
    variant_changes: dict = dc.field(default_factory=dict)


def _task_cell(metrics: dict, name: str) -> str:
    """Whether controller `name` did the experiment's task: "yes", "no" or "unstable"."""
    if name in metrics.get("instability", {}):
        return "unstable"
    task = metrics["controllers"][name].get("task")
    return "–" if task is None else ("yes" if task["done"] else "no")


def robot_comparison(
    perfect: dict, other: dict, label: str, experiment: Experiment
) -> tuple[Table, Table]:
    """The same controllers on the perfect robot and on another (a variant's runs), side
    by side: whether each did the task and its metrics, one row per robot; and each claim's
    verdict under each reading of Q on both.

    Parameters
    ----------
    perfect, other : dict
        The two runs' metrics.json contents (the same controllers).
    label : str
        The other robot's name in the tables, e.g. "real_arm".
    experiment : Experiment
        Its `table` makes the metrics' cells.

    Returns
    -------
    metrics : Table
        Headers "controller", "robot", "task done" and the experiment's metric columns.
    claims : Table
        Headers "claim", "reading", "perfect" and `label`.
    """
    runs = {"perfect": perfect, label: other}
    headers = experiment.table({}).headers
    metrics_table = Table([headers[0], "robot", "task done", *headers[1:]])
    for name in perfect["controllers"]:
        for robot, metrics in runs.items():
            if name not in metrics["controllers"]:
                continue
            row = experiment.table({name: metrics["controllers"][name]}).rows[0]
            metrics_table.add(row[0], robot, _task_cell(metrics, name), *row[1:])
    claims_table = Table(["claim", "reading", "perfect", label])
    for learner, by_claim in perfect["claims"].items():
        reading = reading_label(learner, perfect.get("learners", {}))
        for claim_name, claim in by_claim.items():
            theirs = other["claims"].get(learner, {}).get(claim_name)
            claims_table.add(
                claim_name,
                reading,
                verdict_text(claim["holds"]),
                "–" if theirs is None else verdict_text(theirs["holds"]),
            )
    return metrics_table, claims_table


def _status_html(metrics: dict) -> str:
    """A run folder's status and, for each of its unstable runs, why and when it stopped."""
    stops = [
        f"<code>{html.escape(label)}</code>: {html.escape(problem['reason'])}"
        + ("" if problem["time_s"] is None else f" at t = {problem['time_s']:.3f} s")
        for label, problem in metrics.get("instability", {}).items()
    ]
    return f"Status: <b>{metrics['status']}</b>" + (f" ({'; '.join(stops)})" if stops else "")


ROBOT_KEY = "robot_imperfection"  # what a variant of the robot alone changes (docs/worlds.md)


def _changes_html(changes: list[str] | None) -> tuple[str, str]:
    """(heading, sentence) of a variant that changes the dotted keys `changes`: the robot
    alone (robot_imperfection), or what else; a variant of any values is loaded as such
    (docs/worlds.md: "a YAML document layered over the scenario"), so the page says which."""
    others = [key for key in changes or () if key.split(".")[0] != ROBOT_KEY]
    if changes is not None and not others:
        return (
            "The same controllers on another robot",
            "No gain changed (docs/worlds.md, &ldquo;A robot that is not its model&rdquo;). ",
        )
    if changes is None:
        return "Under a variant", ""
    robot = " and the robot (robot_imperfection)" if len(others) < len(changes) else ""
    controllers = [key for key in others if key.split(".")[0] == "controllers"]
    return (
        "The scenario under a variant",
        "Not the robot alone: against the scenario without it, the variant changes "
        + ", ".join(f"<code>{html.escape(key)}</code>" for key in others)
        + robot
        + ("; controller gains among them. " if controllers else "; no controller gain changed. "),
    )


def _variant_html(
    out_dir: Path,
    perfect: dict,
    variant: str,
    run_dir: Path,
    experiment,
    changes: list[str] | None = None,
) -> str:
    """A variant's runs beside the perfect robot's (`robot_comparison`), with what the
    variant changes (`changes`, its dotted keys; None: not said)."""
    other = json.loads((Path(run_dir) / "metrics.json").read_text())
    rel = Path(run_dir).resolve().relative_to(out_dir.resolve()).as_posix()
    metrics_table, claims_table = robot_comparison(perfect, other, variant, experiment)
    heading, sentence = _changes_html(changes)
    return (
        f"<h3>{heading}: {html.escape(variant)}</h3>"
        f"<p>{sentence}"
        f"{_status_html(other)}. <a href='{rel}/metrics.json'>metrics.json</a> · "
        f"<a href='{rel}/recording.html'>3-D recording</a></p>"
        + to_html(metrics_table)
        + to_html(claims_table, code_first_column=False, verdict_columns=("perfect", variant))
    )


def _probe_html(out_dir: Path, probe_dir: Path) -> str:
    """The world probe's numbers and figure (see `hlcmp probe`, docs/worlds.md)."""
    readings = json.loads((probe_dir / "probe.json").read_text())
    rel = probe_dir.resolve().relative_to(out_dir.resolve()).as_posix()
    return (
        f"<h3>The world alone (hlcmp probe)</h3><p>The tool on a stiff carriage, no controller, at "
        f"{readings['speed_m_per_s']:.3f} m/s: peak resisting force "
        f"<b>{readings['peak_force_N']:.2f} N</b> "
        f"{1000 * readings['depth_at_peak_m']:.1f} mm after first contact, residual "
        f"<b>{readings['residual_force_N']:.2f} N</b>, max lateral force "
        f"<b>{readings['max_lateral_force_N']:.3f} N</b>; {html.escape(readings['status'])}. "
        f"<a href='{rel}/probe.json'>probe.json</a></p>"
        f"<img src='{rel}/probe.png' alt='probe' onerror=\"this.classList.add('missing')\">"
    )


def _title(section: ReportSection) -> str:
    """The experiment's title, and the scenario's name when it is not the bundled one."""
    title = section.experiment.title
    return title if section.name == section.experiment.name else f"{title}: {section.name}"


def report_page(out_dir: Path, sections: list) -> str:
    """index.html text of the report. Every link and image is relative to out_dir, so the
    page works offline.

    Parameters
    ----------
    out_dir : Path
        Where index.html goes; the run folders lie below it.
    sections : list of ReportSection
        One per scenario run, in page order.
    """
    out_dir = Path(out_dir)
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>hlcmp-drake: the paper's "
        f"experiments</title><style>{PAGE_STYLE}</style></head><body>",
        "<h1>Hl-CMPs on Drake: the paper's experiments, reproduced in simulation</h1>",
        "<p>Zeng et al., <i>An Approach for Robotic Learning Inspired by Biomimetic Adaptive "
        "Control</i>, IEEE TII 18(3), 2022. Every number below comes from the runs linked "
        "with it; each claim of the paper is marked reproduced or not.</p>",
        "<h2>Contents</h2><ul>",
    ]
    parts += [f"<li><a href='#{s.name}'>{html.escape(_title(s))}</a></li>" for s in sections]
    parts.append("</ul>")
    for section in sections:
        name, run_dir, experiment = section.name, section.run_dir, section.experiment
        metrics = json.loads((Path(run_dir) / "metrics.json").read_text())
        rel = Path(run_dir).resolve().relative_to(out_dir.resolve()).as_posix()
        parts.append(
            f"<h2 id='{name}'>{html.escape(_title(section))} (paper "
            f"{experiment.paper_figures})</h2>"
        )
        parts.append(
            f"<p>{_status_html(metrics)}; ran in {section.wall_s:.0f} s. "
            f"<a href='{rel}/recording.html'>3-D recording (offline)</a> · "
            f"<a href='{rel}/metrics.json'>metrics.json</a> · "
            f"<a href='{rel}/timeseries.npz'>timeseries.npz</a></p>"
        )
        claims, learners = metrics.get("claims", {}), metrics.get("learners", {})
        verdicts = verdicts_table(claims, learners)
        parts.append(
            "<h3>Claims</h3>"
            + (
                to_html(
                    verdicts, code_first_column=False, verdict_columns=tuple(verdicts.headers[2:])
                )
                + to_html(
                    evidence_table(claims, learners),
                    code_first_column=False,
                    verdict_columns=("reproduced",),
                )
                if any(claims.values())
                else UNSTABLE_NOTE
                if "instability" in metrics
                else "<p>This experiment has no claims.</p>"
            )
        )
        parts.append("<h3>Metrics</h3>" + to_html(experiment.table(metrics["controllers"])))
        for variant, variant_dir in section.variants.items():
            changes = section.variant_changes.get(variant)
            parts.append(_variant_html(out_dir, metrics, variant, variant_dir, experiment, changes))
        if section.probe_dir is not None:
            parts.append(_probe_html(out_dir, Path(section.probe_dir)))
        parts.append("<h3>Figures</h3>")
        for figure in sorted((Path(run_dir) / "figures").glob("*.png")):
            parts.append(
                f"<img src='{rel}/figures/{figure.name}' alt='{figure.stem}' "
                "onerror=\"this.classList.add('missing')\">"
            )
    parts.append("</body></html>")
    return "\n".join(parts) + "\n"
