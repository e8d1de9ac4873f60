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
