"""Atomic outputs, figures and the one Table model rendered three ways."""

import os

import pytest

from hlcmp_drake.experiments.plots import bar_chart, new_figure
from hlcmp_drake.experiments.table import Table, number, per_axis
from hlcmp_drake.io import outputs
from hlcmp_drake.present.tables import to_html, to_markdown, to_text


def test_atomic_write_replaces_whole_or_not_at_all(tmp_path):
    path = tmp_path / "deep" / "metrics.json"
    outputs.write_json(path, {"a": 1})
    assert path.read_text() == '{\n  "a": 1\n}\n'
    assert oct(path.stat().st_mode & 0o777) == oct(0o666 & ~outputs._UMASK)

    def broken(temp):
        with open(temp, "w") as stream:
            stream.write("half")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        outputs.atomic_write(path, broken)
    assert path.read_text() == '{\n  "a": 1\n}\n'  # the old file is intact
    assert os.listdir(path.parent) == ["metrics.json"]  # no temporary left behind


def test_figures_are_made_without_pyplot_and_saved_as_png(tmp_path):
    figure, axes = new_figure(2, 3, size=(6, 4))
    assert len(axes) == 6
    chart = bar_chart({"a": [1, 2, 3], "b": [3, 2, 1]}, ("x", "y", "z"), "value")
    assert [t.get_text() for t in chart.axes[0].get_xticklabels()] == ["x axis", "y axis", "z axis"]
    path = outputs.save_figure(tmp_path / "figures" / "chart.png", chart)
    assert path.read_bytes()[:4] == b"\x89PNG"


def test_cells_are_rounded_without_negative_zero():
    assert number(-0.0001) == "0.00" and number(None) == "never" and number(-1.234, 1) == "-1.2"
    assert per_axis({"x": 0.001, "y": -0.0000001, "z": 0.0125}, "xyz", 1000) == "1.00/0.00/12.50"


def test_one_table_three_renderings():
    table = Table(["controller", "mean |e| [mm]", "reproduced"])
    table.add("hlcmp", "1.25", "yes")
    table.add("const_500", "10.50", "no")
    with pytest.raises(ValueError):
        table.add("too", "few")
    text = to_text(table).splitlines()
    assert (
        text[0].startswith("controller") and text[2].startswith("hlcmp") and text[3].endswith("no")
    )
    assert len({len(line) for line in text[:2]}) == 1  # aligned columns
    markdown = to_markdown(table)
    assert "| `hlcmp` | 1.25 | yes |" in markdown and "mean \\|e\\| [mm]" in markdown
    html = to_html(table, verdict_columns=("reproduced",))
    assert "<td class='yes'>yes</td>" in html and "<code>const_500</code>" in html
