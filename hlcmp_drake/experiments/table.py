"""The one row model every result table is made of: headers and formatted cells.

Experiments turn their metrics into a Table once; `hlcmp_drake.present.tables` renders
it as terminal text, markdown (README) or HTML (report)."""

from __future__ import annotations

import dataclasses as dc


@dc.dataclass
class Table:
    """A table of formatted cells.

    Attributes
    ----------
    headers : list of str
        Column headers, readable and with units, e.g. "mean |e| x/y/z [mm]".
    rows : list of list of str
        One list of cells per row, as many as headers; the first cell names the row
        (a controller label, a trial), rendered as code where the format has it.
    """

    headers: list
    rows: list = dc.field(default_factory=list)

    def add(self, *cells) -> None:
        """Append one row (as many cells as headers)."""
        if len(cells) != len(self.headers):
            raise ValueError(f"a row needs {len(self.headers)} cells, got {len(cells)}")
        self.rows.append([str(cell) for cell in cells])


def per_axis(values: dict, axes: str | tuple, scale: float = 1.0, digits: int = 2) -> str:
    """'a/b/c' for a per-axis metric, scaled and rounded (never '-0').

    Parameters
    ----------
    values : dict of str to float
        {axis name: value}.
    axes : iterable of str
        The axes to show, in order, e.g. ("x", "y", "z").
    scale : float
        Factor applied before rounding (1000 for metres shown in mm).
    digits : int
        Decimals.
    """
    return "/".join(number(values[a] * scale, digits) for a in axes)


def number(value: float | None, digits: int = 2) -> str:
    """A rounded number for a cell: 'never' for None, and no negative zero.

    Parameters
    ----------
    value : float or None
        None stands for an event that never happened (a time never reached).
    digits : int
        Decimals.
    """
    if value is None:
        return "never"
    text = f"{value:.{digits}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text
