"""The data-set figure: every training trajectory and some test trajectories."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.collections import LineCollection

from ..variables import INPUTS, STATES, label
from .style import TEST_COLOR, TRAIN_COLOR


def plot_datasets(train: pd.DataFrame, test: pd.DataFrame, test_trajectories: int = 10) -> plt.Figure:
    """13 panels (x1..x8, u1..u5) over time [h]: training set blue, test set orange."""
    shown = np.sort(test["trajectory"].unique())[:test_trajectories]
    test = test[test["trajectory"].isin(shown)]
    names = (*STATES, *INPUTS)
    fig, axes = plt.subplots(5, 3, figsize=(15, 17), sharex=True)
    for ax, name in zip(axes.flat, names, strict=False):
        for table, color in ((train, TRAIN_COLOR), (test, TEST_COLOR)):
            ax.add_collection(LineCollection(_segments(table, name), colors=color, linewidths=0.6, alpha=0.6))
        ax.autoscale_view()
        ax.set_title(label(name), fontsize=10)
    for index in range(len(names), axes.size):
        axes.flat[index].set_visible(False)
    for column in range(axes.shape[1]):
        bottom = axes[max(r for r in range(axes.shape[0]) if axes[r, column].get_visible()), column]
        bottom.xaxis.set_tick_params(labelbottom=True)
        bottom.set_xlabel("time [h]")
    handles = [plt.Line2D([], [], color=TRAIN_COLOR), plt.Line2D([], [], color=TEST_COLOR)]
    fig.legend(handles, [f"training ({train['trajectory'].nunique()})", f"test ({len(shown)} shown)"],
               loc="lower right", bbox_to_anchor=(0.95, 0.08))  # fmt: skip
    fig.tight_layout()
    return fig


def _segments(table: pd.DataFrame, column: str) -> list[np.ndarray]:
    """One (K, 2) polyline of (time [h], value) per trajectory."""
    return [
        np.column_stack([group["time_s"].to_numpy() / 3600, group[column].to_numpy()])
        for _, group in table.groupby("trajectory", sort=True)
    ]
