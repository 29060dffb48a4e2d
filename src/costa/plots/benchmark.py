"""The benchmark's recall against the signal, one line per sensor set."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import seaborn as sns


def plot_recall_by_signal(curve: pd.DataFrame, cases: pd.DataFrame) -> plt.Figure:
    """Left: recall per signal bin with its Wilson 95 % interval (:func:`costa.benchmark.score.recall_by_signal`);
    right: every drawn case with an effect at its signal, right (1) or not (0), per sensor set."""
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    sets = list(dict.fromkeys(curve["sensors"]))
    palette = dict(zip(sets, sns.color_palette("colorblind", len(sets)), strict=True))
    offsets = np.linspace(-0.06, 0.06, len(sets))
    for offset, (sensor_set, group) in zip(offsets, curve.groupby("sensors", sort=False), strict=True):
        group = group[group["effects"] > 0]
        low = group["signal_from"].clip(lower=0.3)
        high = group["signal_to"].clip(upper=group["signal_from"].clip(lower=1) * 30)
        centre = np.sqrt(low * high) * 10**offset
        left.errorbar(
            centre, group["recall"], yerr=[group["recall"] - group["recall_low"], group["recall_high"] - group["recall"]],
            marker="o", capsize=3, color=palette[sensor_set], label=sensor_set,
        )  # fmt: skip
    left.set(xscale="log", xlabel="signal (noise units)", ylabel="recall (named right)", ylim=(-0.03, 1.03))
    left.legend(title="sensors", frameon=False)
    effects = cases[cases["kind"] != "none"].copy()
    effects["named right"] = (effects["verdict"] == "right").astype(float)
    effects["signal"] = effects["signal"].clip(lower=0.1, upper=1e6)
    for sensor_set, group in effects.groupby("sensors", sort=False):
        jitter = np.random.default_rng(0).uniform(-0.06, 0.06, len(group))
        right.scatter(group["signal"], group["named right"] + jitter, s=14, alpha=0.7, color=palette.get(sensor_set))
    right.set(
        xscale="log", xlabel="signal (noise units)", yticks=[0, 1], yticklabels=["not named right", "named right"]
    )
    fig.tight_layout()
    return fig
