"""Figure helpers shared by the experiments' figures.

Figures are plain matplotlib `Figure` objects (no pyplot, no global backend), so making
them needs no display and leaves an interactive session's backend alone."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def new_figure(
    rows: int, cols: int, size: tuple, sharex: bool = False
) -> tuple[Figure, np.ndarray]:
    """A Figure with a rows x cols grid of axes.

    Parameters
    ----------
    rows, cols : int
    size : (width, height)
        In inches.
    sharex : bool
        Share the x axis within each column.

    Returns
    -------
    (Figure, array of Axes)
        The axes flattened row by row.
    """
    # Imported here: the processes that never plot (serve, sim-driver) skip matplotlib's
    # import, most of their start-up.
    from matplotlib.figure import Figure

    figure = Figure(figsize=size, layout="constrained")
    axes = figure.subplots(rows, cols, sharex=sharex, squeeze=False)
    return figure, axes.ravel()


def controller_colors(labels: Iterable[str]) -> dict:
    """One colour per controller, by its place in `labels` (matplotlib's C0, C1, ...), so
    that a controller keeps its colour in every panel of a figure, as in the recording.

    Parameters
    ----------
    labels : iterable of str
        The controllers' labels, in the scenario's order.

    Returns
    -------
    dict of str to str
        {label: hex colour}; the cycle of ten colours repeats after the tenth.
    """
    from matplotlib.colors import to_hex

    return {label: to_hex(f"C{k % 10}") for k, label in enumerate(labels)}


def bar_chart(values: dict, groups: tuple, ylabel: str) -> Figure:
    """Grouped bars, one group per entry of `groups` (labelled "<group> axis").

    Parameters
    ----------
    values : dict of str to list of float
        {series name (a controller): one value per group}.
    groups : sequence of str
        The groups, e.g. the axes ("x", "y", "z").
    ylabel : str
        The value axis' label, with units.
    """
    figure, (axis,) = new_figure(1, 1, size=(8, 4.5))
    width = 0.8 / len(values)
    for k, (name, series) in enumerate(values.items()):
        axis.bar(
            np.arange(len(groups)) + (k - (len(values) - 1) / 2) * width, series, width, label=name
        )
    axis.set_xticks(range(len(groups)), [f"{g} axis" for g in groups])
    axis.set_ylabel(ylabel)
    axis.grid(alpha=0.3, axis="y")
    axis.legend(fontsize=8)
    return figure
