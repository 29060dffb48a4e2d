"""The paper's result figures: error violins, blow-up bars, a rolling forecast."""

from __future__ import annotations

from collections.abc import Sequence

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import seaborn as sns

from ..variables import INPUTS, STATES, label
from .style import TRUTH_COLOR, model_color, model_label


def _order(metrics: pd.DataFrame) -> tuple[list[str], list[str]]:
    known = [
        "ddm_dense",
        "ddm_sparse",
        "costa_dense",
        "costa_sparse",
        "costa_bounded",
        "costa_smooth",
        "pbm",
        "discovered",
    ]
    present = list(dict.fromkeys(metrics["model_type"]))
    types = [t for t in known if t in present] + [t for t in present if t not in known]
    return types, list(dict.fromkeys(metrics["window"]))


def plot_error_violins(metrics: pd.DataFrame, definition: str = "coded") -> plt.Figure:
    """AN-RFMSE of the rollouts that did not blow up, by window and model type (log scale)."""
    data = metrics[(metrics["definition"] == definition) & ~metrics["blown_up"]]
    types, windows = _order(data)
    fig, ax = plt.subplots(figsize=(11, 4.8))
    sns.violinplot(
        data=data, x="window", y="error", hue="model_type", order=windows, hue_order=types,
        palette={t: model_color(t) for t in types}, log_scale=True, cut=0, inner="quart",
        density_norm="width", linewidth=0.8, saturation=0.9, ax=ax,
    )  # fmt: skip
    for text in ax.legend_.texts:
        text.set_text(model_label(text.get_text()))
    ax.legend_.set_title(None)
    ax.set(xlabel="window", ylabel=f"AN-RFMSE ({definition}), blow-ups excluded")
    ax.grid(axis="y", which="both", alpha=0.3)
    fig.tight_layout()
    return fig


def plot_blowups(metrics: pd.DataFrame, definition: str = "coded") -> plt.Figure:
    """How many rollouts blew up, by window and model type (counts on the bars)."""
    data = metrics[metrics["definition"] == definition]
    types, windows = _order(data)
    counts = data.groupby(["window", "model_type"], sort=False).agg(
        blowups=("blown_up", "sum"), rollouts=("blown_up", "size")
    )
    counts = counts.reset_index()
    fig, ax = plt.subplots(figsize=(11, 4.8))
    sns.barplot(
        data=counts, x="window", y="blowups", hue="model_type", order=windows, hue_order=types,
        palette={t: model_color(t) for t in types}, ax=ax,
    )  # fmt: skip
    for container in ax.containers:
        ax.bar_label(container, fmt="%d", fontsize=8)
    totals = counts.groupby("model_type")["rollouts"].first()
    for text in ax.legend_.texts:
        text.set_text(f"{model_label(text.get_text())} (of {totals[text.get_text()]})")
    ax.legend_.set_title(None)
    ax.set(xlabel="window", ylabel="blow-ups")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return fig


def plot_rolling_forecast(
    truth: pd.DataFrame,
    forecasts: pd.DataFrame,
    types: Sequence[str],
    physics: Sequence[str] = ("pbm",),
    physics_liquidus: float | None = 968.0,
) -> plt.Figure:
    """14 panels over time [h]: x1..x8, g1 and u1..u5 of one test trajectory.

    ``truth`` is the trajectory's rows of the test table; ``forecasts`` holds the
    saved forecasts of ``types`` (mean and mean +- 3 std over instances, the paper's
    99.7 % band) and of the ``physics`` models (one line each; the first is the
    PBM whose constant liquidus temperature is drawn).
    """
    hours = truth["time_s"].to_numpy() / 3600
    fig, axes = plt.subplots(5, 3, figsize=(15, 17), sharex=True)
    panels = [*STATES, "g1", *INPUTS]
    for ax, name in zip(axes.flat, panels, strict=False):
        ax.plot(hours, truth[name].to_numpy(), color=TRUTH_COLOR, lw=1.2, label="truth")
        ax.set_title(label(name), fontsize=10)
        if name in STATES:
            _draw_forecasts(ax, hours, forecasts, name, types, physics, truth[name].to_numpy())
    g1_axis = axes.flat[panels.index("g1")]
    if physics_liquidus is not None:
        g1_axis.axhline(physics_liquidus, color=model_color(physics[0]), ls="--", lw=1.2)
    axes.flat[-1].set_visible(False)
    for ax in axes[-1][:2]:
        ax.set_xlabel("time [h]")
    axes[-2][2].xaxis.set_tick_params(labelbottom=True)
    axes[-2][2].set_xlabel("time [h]")
    handles, labels = axes.flat[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower right", bbox_to_anchor=(0.95, 0.06), fontsize=10)
    fig.tight_layout()
    return fig


def _draw_forecasts(ax, hours, forecasts, name, types, physics, truth_values) -> None:
    for model in types:
        wide = forecasts[forecasts["model_type"] == model].pivot(index="instance", columns="step", values=name)
        values = wide.to_numpy(dtype=np.float64)
        with np.errstate(all="ignore"):
            mean, spread = np.nanmean(values, axis=0), 3 * np.nanstd(values, axis=0, ddof=1)
        color = model_color(model)
        ax.plot(hours, mean, color=color, ls="--", lw=1.1, label=f"{model_label(model)} (mean)")
        ax.fill_between(
            hours, mean - spread, mean + spread, color=color, alpha=0.25, lw=0, label=f"{model_label(model)} 99.7 %"
        )
    for model in physics:
        line = forecasts[forecasts["model_type"] == model].sort_values("step")
        if not line.empty:
            ax.plot(hours, line[name].to_numpy(), color=model_color(model), ls="--", lw=1.1, label=model_label(model))
    low, high = np.nanmin(truth_values), np.nanmax(truth_values)
    margin = max(0.5 * (high - low), 1e-3 * max(abs(high), 1.0))
    ax.set_ylim(low - margin, high + margin)  # a blown-up instance must not hide the others
