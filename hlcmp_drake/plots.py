"""Matplotlib set-up shared by the experiments' figures (headless, no display needed)."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402


def new_figure(rows, cols, size, sharex=False):
    figure, axes = plt.subplots(rows, cols, figsize=size, sharex=sharex, squeeze=False,
                                constrained_layout=True)
    return figure, axes.ravel()


def bar_chart(values, groups, ylabel):
    """Grouped bars: values = {series name: [one value per group]}."""
    import numpy as np

    figure, (axis,) = new_figure(1, 1, size=(8, 4.5))
    width = 0.8 / len(values)
    for k, (name, series) in enumerate(values.items()):
        axis.bar(np.arange(len(groups)) + (k - (len(values) - 1) / 2) * width, series, width, label=name)
    axis.set_xticks(range(len(groups)), [f"{g} axis" for g in groups])
    axis.set_ylabel(ylabel)
    axis.grid(alpha=0.3, axis="y")
    axis.legend(fontsize=8)
    return figure
