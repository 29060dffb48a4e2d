"""Blow-up counts across replicates of the experiment, beside the paper's."""

from __future__ import annotations

import matplotlib.pyplot as plt
import pandas as pd
import seaborn as sns
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from .results import _order
from .style import model_color, model_label


def plot_replicate_blowups(per_replicate: pd.DataFrame, paper: pd.DataFrame) -> plt.Figure:
    """Blow-ups per model type, one panel per window: a point per replicate, a line at their mean, the paper's count.

    ``per_replicate`` has replicate, model_type, window and blowups
    (:func:`costa.replicates.per_replicate_table`); ``paper`` has model_type, window and
    paper_blowups (:func:`costa.paper.paper_blowups`; missing values are not drawn).
    """
    types, windows = _order(per_replicate)
    palette = {t: model_color(t) for t in types}
    fig, axes = plt.subplots(1, len(windows), figsize=(4.2 * len(windows), 4.6), squeeze=False)
    for ax, window in zip(axes[0], windows, strict=True):
        data = per_replicate[per_replicate["window"] == window]
        sns.stripplot(
            data=data, x="model_type", y="blowups", hue="model_type", order=types, hue_order=types, palette=palette,
            jitter=0.15, size=6, alpha=0.85, legend=False, zorder=3, ax=ax,
        )  # fmt: skip
        means = data.groupby("model_type")["blowups"].mean()
        marks = paper[paper["window"] == window].set_index("model_type")["paper_blowups"]
        for position, model in enumerate(types):
            ax.hlines(means[model], position - 0.3, position + 0.3, color=palette[model], lw=1.2, ls="--")
            if pd.notna(marks.get(model)):
                ax.hlines(marks[model], position - 0.35, position + 0.35, color="black", lw=2.2)
        ax.set_xticks(range(len(types)), [model_label(t) for t in types], rotation=30, ha="right")
        ax.set(title=f"{window} window", xlabel=None, ylabel="blow-ups" if ax is axes[0][0] else None)
        top = 1.08 * max(data["blowups"].max(), marks.max(), 1)  # a window without blow-ups still reads 0..1
        ax.set_ylim(-0.04 * top, top)
        ax.yaxis.set_major_locator(MaxNLocator(integer=True))
        ax.grid(axis="y", alpha=0.3)
    handles = [
        Line2D([], [], color="grey", marker="o", ls="none", label="one replicate"),
        Line2D([], [], color="grey", ls="--", label="mean over replicates"),
        Line2D([], [], color="black", lw=2.2, label="paper"),
    ]
    fig.legend(handles=handles, loc="upper center", ncol=3, bbox_to_anchor=(0.5, 1.06), frameon=False)
    fig.tight_layout()
    return fig
