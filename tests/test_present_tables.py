"""hlcmp_drake.present.tables: the one Table model rendered three ways (text, Markdown, HTML)."""

import pytest

from hlcmp_drake.experiments.table import Table
from hlcmp_drake.present.tables import to_html, to_markdown, to_text


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


def test_a_long_first_column_wraps_to_the_width_with_its_values_on_the_first_line():
    label = "one_dof_rtf: simulated s per wall s of the slowest 1-DOF controller on the fast path"
    table = Table(["measure", "value", "target"])
    table.add(label, "10.63", "≥ 20")
    table.add("dmp_fit_ms", "4.5 ms", "")
    one_line = to_text(table).splitlines()
    assert len(one_line) == 4 and one_line[2].startswith(label)  # no width: one line a row
    for width in (60, 10):  # 10: narrower than the first column may go
        lines = to_text(table, width=width).splitlines()
        first = next(k for k, line in enumerate(lines) if line.startswith("one_dof_rtf"))
        last = next(k for k, line in enumerate(lines) if line.startswith("dmp_fit_ms"))
        assert last - first >= 2 and lines[first].split()[-3:] == ["10.63", "≥", "20"]
        column = len(lines[1].split()[0])  # the rule's first dashes
        wrapped = [line[:column].strip() for line in lines[first:last]]
        assert " ".join(wrapped) == label  # no word split or lost
        assert all(line[column:].strip() == "" for line in lines[first + 1 : last])
        assert lines[last].endswith("4.5 ms")
        assert column == max(20, min(len(label), width - 16))
        assert all(len(line) <= max(width, column + 16) for line in lines)
