"""A Table (hlcmp_drake.experiments.table) rendered three ways: aligned terminal text,
markdown for the README, HTML for the report page."""

from __future__ import annotations

import html

from hlcmp_drake.experiments.table import Table


def to_text(table: Table) -> str:
    """Columns aligned with spaces: the first left-aligned, the others right-aligned.

    Parameters
    ----------
    table : Table
    """
    widths = [
        max(len(row[k]) for row in [table.headers, *table.rows]) for k in range(len(table.headers))
    ]

    def line(cells):
        return "  ".join(
            cell.ljust(w) if k == 0 else cell.rjust(w)
            for k, (cell, w) in enumerate(zip(cells, widths))
        ).rstrip()

    return "\n".join(
        [line(table.headers), "  ".join("-" * w for w in widths)] + [line(r) for r in table.rows]
    )


def _markdown_cell(text: str) -> str:
    return text.replace("|", "\\|")  # a literal bar inside a table cell


def to_markdown(table: Table, code_first_column: bool = True) -> str:
    """A GitHub markdown table.

    Parameters
    ----------
    table : Table
    code_first_column : bool
        Show the first column's cells as `code` (controller labels).
    """

    def first(cell):
        return f"`{cell}`" if code_first_column else _markdown_cell(cell)

    lines = [
        "| " + " | ".join(_markdown_cell(h) for h in table.headers) + " |",
        "|" + "---|" * len(table.headers),
    ]
    lines += [
        "| " + " | ".join([first(row[0])] + [_markdown_cell(c) for c in row[1:]]) + " |"
        for row in table.rows
    ]
    return "\n".join(lines) + "\n"


def to_html(table: Table, code_first_column: bool = True, verdict_columns: tuple = ()) -> str:
    """An HTML table, scrolling sideways when wide.

    Parameters
    ----------
    table : Table
    code_first_column : bool
        Show the first column's cells as <code>.
    verdict_columns : tuple of str
        Headers of columns whose cells get the class of their text ("yes"/"no"), for colour.
    """
    verdicts = {table.headers.index(h) for h in verdict_columns if h in table.headers}
    head = "".join(f"<th>{html.escape(h)}</th>" for h in table.headers)
    rows = [f"<tr>{head}</tr>"]
    for row in table.rows:
        cells = []
        for k, cell in enumerate(row):
            text = html.escape(cell)
            if k == 0 and code_first_column:
                text = f"<code>{text}</code>"
            cls = f" class='{html.escape(cell)}'" if k in verdicts else ""
            cells.append(f"<td{cls}>{text}</td>")
        rows.append(f"<tr>{''.join(cells)}</tr>")
    return "<div style='overflow-x: auto'><table>" + "".join(rows) + "</table></div>"
