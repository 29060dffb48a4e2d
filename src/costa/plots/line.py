"""A pot line at a glance: how far each pot's channels disagree with the starting model."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import seaborn as sns


def plot_line(table: pd.DataFrame, groups: list[dict]) -> plt.Figure:
    """Pots (rows) x channels (columns): log10 of each channel's chi2/dof under the starting model (0: agrees
    with its noise), a cross where the channel disagrees; each pot labelled with its group and, on a
    simulated line, the effect hidden in it.  ``table``: :func:`costa.line.groups.line_table`."""
    group_of = {pot: g["group"] for g in groups for pot in g["pots"]}
    chi2 = table.pivot(index="pot", columns="channel", values="chi2_per_dof")
    flagged = table.pivot(index="pot", columns="channel", values="flagged").reindex_like(chi2).fillna(False)
    hidden = table.groupby("pot")["hidden"].first().reindex(chi2.index)
    labels = [
        f"{pot} {group_of.get(pot, '-')}" + (f"  ({hidden[pot]})" if hidden[pot] and hidden[pot] != "no_effect" else "")
        for pot in chi2.index
    ]
    fig, ax = plt.subplots(figsize=(1.1 * chi2.shape[1] + 4.0, 0.32 * len(chi2) + 1.6))
    values = np.log10(chi2.clip(lower=1e-3).astype(float))
    sns.heatmap(values, cmap="rocket_r", vmin=0.0, vmax=max(2.0, float(np.nanmax(values.to_numpy()))), ax=ax,
                cbar_kws={"label": "log10 chi2/dof"}, yticklabels=labels)  # fmt: skip
    for i, j in zip(*np.nonzero(flagged.to_numpy().astype(bool)), strict=True):
        ax.text(j + 0.5, i + 0.5, "x", ha="center", va="center", color="white", fontsize=9, fontweight="bold")
    ax.set(xlabel="measured channel", ylabel="pot, its group (hidden effect)",
           title="The line under the starting model (x: disagrees beyond noise)")  # fmt: skip
    fig.tight_layout()
    return fig
