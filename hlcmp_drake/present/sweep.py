"""A sweep's results as a table and as one plot per swept parameter, both made from the
content of its sweep.json alone (so the README's blocks need no rerun).

sweep.json holds `parameters` ([{key, label}], in column order), `metrics` ([{label,
digits, missing, yes_no}]) and `tasks` ([{id, parameters: {key: YAML text}, repetition,
status, values: {label: value}, wall_s}]); see `hlcmp_drake.run.sweep`."""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING

import numpy as np
import yaml

from hlcmp_drake.config.sweep import number_of, short_names
from hlcmp_drake.experiments.plots import new_figure
from hlcmp_drake.experiments.table import Table, number

if TYPE_CHECKING:
    from matplotlib.figure import Figure

FINISHED = ("ok", "unstable")


def parameter_number(text: str) -> float | None:
    """The number a parameter's YAML value stands for: the number itself, or the one
    value of a list whose entries are all equal ("[10.0, 10.0, 10.0]" -> 10); None when
    it is no number.

    Parameters
    ----------
    text : str
        The YAML value text (or a case's label).

    Returns
    -------
    float or None
    """
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        return None
    if isinstance(value, list) and value and all(v == value[0] for v in value):
        value = value[0]
    number = number_of(value)
    return number if number is not None and math.isfinite(number) else None


def parameter_text(text: str) -> str:
    """A parameter's value for a table cell: its number in shortest form ("1.0" -> "1",
    "[10.0]" -> "10"), else its text.

    Parameters
    ----------
    text : str
        The YAML value text (or a case's label).
    """
    value = parameter_number(text)
    return text if value is None else f"{value:g}"


def cell(value: object, metric: dict) -> str:
    """One metric's table cell: yes/no, a number with the metric's decimals, its
    `missing` text for null, or the value's text.

    Parameters
    ----------
    value : object
        From sweep.json: a number, a bool, a string or None.
    metric : dict
        The metric's entry of sweep.json (digits, missing).
    """
    if value is None:
        return metric.get("missing", "n/a")
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, float)):
        return number(float(value), metric.get("digits", 2))
    return str(value)


def sweep_table(summary: dict) -> Table:
    """The finished tasks as rows: the swept values (a repetition column when the sweep
    repeats), then the metrics, then a status column when some task was not ok.

    Parameters
    ----------
    summary : dict
        A sweep.json content.

    Returns
    -------
    Table
    """
    parameters, metrics = summary["parameters"], summary["metrics"]
    finished = [task for task in summary["tasks"] if task["status"] in FINISHED]
    repeats = summary.get("repetitions", 1) > 1
    flagged = any(task["status"] != "ok" for task in finished)
    headers = (
        [p["label"] for p in parameters]
        + (["rep"] if repeats else [])
        + [m["label"] for m in metrics]
    )
    if not parameters and not repeats:
        headers = ["task"] + headers
    headers += ["status"] if flagged else []
    table = Table(headers)
    for task in finished:
        cells = [parameter_text(task["parameters"][p["key"]]) for p in parameters]
        cells += [str(task["repetition"])] if repeats else []
        if not parameters and not repeats:
            cells = [task["id"]] + cells
        cells += [cell(task["values"].get(m["label"]), m) for m in metrics]
        cells += [task["status"]] if flagged else []
        table.add(*cells)
    return table


def _file_name(key: str) -> str:
    return re.sub(r"[^A-Za-z0-9._\-]", "_", key) + ".png"


def _plotted(summary: dict, finished: list) -> list:
    """(label, values by task id) of every metric with a number in it; the wall time
    when there is none."""
    out = []
    for metric in summary["metrics"]:
        if metric.get("yes_no"):
            continue
        values = {t["id"]: t["values"].get(metric["label"]) for t in finished}
        numbers = {
            k: float(v)
            for k, v in values.items()
            if isinstance(v, (int, float)) and not isinstance(v, bool)
        }
        if numbers:
            out.append((metric["label"], numbers))
    if not out:
        out.append(
            (
                "wall time [s]",
                {t["id"]: t["wall_s"] for t in finished if t.get("wall_s") is not None},
            )
        )
    return out


def sweep_figures(summary: dict) -> dict[str, Figure]:
    """One figure per swept parameter: each numeric metric against the parameter's value,
    one line per combination of the other parameters (repetitions averaged, each run a
    dot). A parameter whose values are not all numbers is drawn at evenly spaced ticks
    labelled with its values; numbers spanning more than a factor of 50 on a log axis.

    Parameters
    ----------
    summary : dict
        A sweep.json content (its finished tasks are drawn).

    Returns
    -------
    dict of str to Figure
        {"KEY.png": Figure} per parameter ("case.png" for the cases); empty before any
        task has finished.
    """
    finished = [task for task in summary["tasks"] if task["status"] in FINISHED]
    if not finished:
        return {}
    plotted = _plotted(summary, finished)
    keys = [p["key"] for p in summary["parameters"]]
    names = short_names(keys)
    figures = {}
    for parameter in summary["parameters"]:
        key = parameter["key"]
        texts = list(dict.fromkeys(task["parameters"][key] for task in finished))
        numbers = [parameter_number(text) for text in texts]
        numeric = all(n is not None for n in numbers) and len(set(numbers)) == len(numbers)
        position = dict(zip(texts, numbers if numeric else range(len(texts))))
        others = [k for k in keys if k != key]
        figure, axes = new_figure(
            len(plotted), 1, size=(7.5, 0.8 + 2.6 * len(plotted)), sharex=True
        )
        for axis, (label, values) in zip(axes, plotted):
            groups = {}
            for task in finished:
                if task["id"] in values:
                    group = tuple(task["parameters"][k] for k in others)
                    groups.setdefault(group, {}).setdefault(task["parameters"][key], []).append(
                        values[task["id"]]
                    )
            for group, by_value in groups.items():
                xs = [position[text] for text in texts if text in by_value]
                means = [float(np.mean(by_value[text])) for text in texts if text in by_value]
                name = (
                    ", ".join(f"{names[k]}={parameter_text(v)}" for k, v in zip(others, group))
                    or None
                )
                (line,) = axis.plot(xs, means, marker="o", label=name)
                for text in texts:
                    if text in by_value and len(by_value[text]) > 1:
                        axis.plot(
                            [position[text]] * len(by_value[text]),
                            by_value[text],
                            ".",
                            color=line.get_color(),
                            alpha=0.5,
                        )
            axis.set_ylabel(label)
            axis.grid(alpha=0.3)
            if 1 < len(groups) <= 12:
                axis.legend(fontsize=7, loc="best")
        if numeric and min(numbers) > 0 and max(numbers) / min(numbers) > 50:
            axes[-1].set_xscale("log")
        if not numeric:
            axes[-1].set_xticks(range(len(texts)), texts)
        axes[-1].set_xlabel(parameter["label"])
        axes[0].set_title(f"sweep of {parameter['label']} ({summary.get('name', '')})")
        figures[_file_name(key)] = figure
    return figures
