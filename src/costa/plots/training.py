"""Training curves: loss per epoch of every instance, one panel per model type."""

from __future__ import annotations

import matplotlib.pyplot as plt
import pandas as pd
import seaborn as sns

from .style import model_color, model_label


def plot_training_curves(losses: pd.DataFrame) -> plt.Figure:
    """Tidy losses (model_type, instance, epoch, mse, l1_penalty, loss) -> one panel per type."""
    types = list(dict.fromkeys(losses["model_type"]))
    fig, axes = plt.subplots(1, len(types), figsize=(4 * len(types), 3.6), sharey=True, squeeze=False)
    for ax, name in zip(axes[0], types, strict=True):
        part = losses[losses["model_type"] == name]
        color = model_color(name)
        sns.lineplot(data=part, x="epoch", y="mse", units="instance", estimator=None, color=color, lw=1, ax=ax)
        if (part["l1_penalty"] > 0).any():
            sns.lineplot(
                data=part, x="epoch", y="loss", units="instance", estimator=None, color=color, lw=1, ls="--", ax=ax
            )
        ax.set(yscale="log", title=model_label(name), xlabel="epoch", ylabel="training loss (standardised)")
    fig.tight_layout()
    return fig
