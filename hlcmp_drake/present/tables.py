"""A Table (hlcmp_drake.experiments.table) rendered three ways: aligned terminal text,
markdown for the README, HTML for the report page."""

from __future__ import annotations

import html
import textwrap

from hlcmp_drake.experiments.table import Table

# A wrapped first column keeps at least this many characters a line.
MIN_FIRST_WIDTH = 20


def to_text(table: Table, width: int | None = None) -> str:
    """Columns aligned with spaces: the first left-aligned, the others right-aligned.

    Parameters
    ----------
    table : Table
    width : int, optional
        The widest line wanted (a terminal's columns): a first column that would make
        the lines wider is wrapped at spaces onto lines of its own below its row's first,
        never narrower than its longest word or `MIN_FIRST_WIDTH`. None: no wrapping.

    Returns
    -------
    str
        The header, a rule of dashes, then the rows, one per line unless wrapped.
    """
    widths = [
        max(len(row[k]) for row in [table.headers, *table.rows]) for k in range(len(table.headers))
    ]
    if width is not None:
        others = sum(w + 2 for w in widths[1:])
        longest_word = max(
            len(word) for row in [table.headers, *table.rows] for word in row[0].split() or [""]
        )
        widths[0] = min(widths[0], max(width - others, longest_word, MIN_FIRST_WIDTH))

    def lines(cells):  # a row's lines: the wrapped first cell, the others on its first
        first = (
            [cells[0]]
            if len(cells[0]) <= widths[0]
            else textwrap.wrap(cells[0], widths[0], break_long_words=False)
        )
        rest = ["  ".join(cell.rjust(w) for cell, w in zip(cells[1:], widths[1:]))]
        rest += [""] * (len(first) - 1)
        return [
            f"{text.ljust(widths[0])}  {others}".rstrip() if others else text.rstrip()
            for text, others in zip(first, rest)
        ]

    rule = ["  ".join("-" * w for w in widths)]
    return "\n".join(lines(table.headers) + rule + [ln for row in table.rows for ln in lines(row)])


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
