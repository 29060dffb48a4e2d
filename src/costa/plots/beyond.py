"""The noise study: median error and blow-ups per window against the training data's noise."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from .results import _order
from .style import model_color, model_label


def plot_noise_study(table: pd.DataFrame) -> plt.Figure:
    """Two rows (median AN-RFMSE, blow-ups) by window; x is the noise level [% of each state's std].

    ``table`` is :func:`costa.beyond.noise_table`: noise, model_type, window, replicates,
    rollouts, median_mean/low/high and blowups_mean/low/high.  A point is the mean over
    replicates, its bar the bootstrap interval; the x axis is symmetric-log so that 0 % shows.
    """
    types, windows = _order(table)
    fig, axes = plt.subplots(2, len(windows), figsize=(4.4 * len(windows), 7.2), squeeze=False, sharex=True)
    offsets = np.linspace(-0.04, 0.04, len(types))  # in log10 units: markers side by side
    for column, window in enumerate(windows):
        for row, (stat, ylabel) in enumerate((("median", "median AN-RFMSE"), ("blowups", "blow-ups per replicate"))):
            ax = axes[row][column]
            for offset, model in zip(offsets, types, strict=True):
                part = table[(table["model_type"] == model) & (table["window"] == window)].sort_values("noise")
                x = part["noise"].to_numpy(dtype=float)
                x = np.where(x > 0, x * 10**offset, 0.0)
                mean = part[f"{stat}_mean"].to_numpy(dtype=float)
                err = np.abs(np.vstack([mean - part[f"{stat}_low"], part[f"{stat}_high"] - mean]).astype(float))
                ax.errorbar(
                    x, mean, yerr=np.nan_to_num(err), color=model_color(model), marker="o", ms=4, lw=1.2,
                    capsize=2, label=f"{model_label(model)} (of {int(part['rollouts'].max())})",
                )  # fmt: skip
            ax.set_xscale("symlog", linthresh=0.5)
            levels = sorted(table["noise"].unique())
            ax.set_xticks(levels, [f"{level:g}" for level in levels])
            ax.xaxis.set_minor_locator(plt.NullLocator())
            if stat == "median":
                ax.set_yscale("log")
                ax.set_title(f"{window} window")
            ax.set(ylabel=ylabel if column == 0 else None)
            if row == 1:
                ax.set_xlabel("noise on the training data [% of state std]")
            ax.grid(alpha=0.3, which="both")
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncol=min(len(types), 4), bbox_to_anchor=(0.5, 1.05), frameon=False)
    fig.tight_layout()
    return fig
