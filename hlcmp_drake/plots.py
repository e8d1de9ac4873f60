"""Matplotlib set-up shared by the experiments' figures (headless, no display needed)."""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402


def new_figure(rows, cols, size, sharex=False):
    figure, axes = plt.subplots(rows, cols, figsize=size, sharex=sharex, squeeze=False,
                                constrained_layout=True)
    return figure, axes.ravel()
