"""A discovery case at a glance: which equations disagree, round by round, and the gap."""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

#: the gap's models in reading order, with their colours
GAP_MODELS = {"starting model": "#d62728", "corrected model": "#2ca02c", "CoSTA reference": "#ff7f0e"}


def _stages(rounds) -> list[tuple[str, dict[str, float]]]:
    """(label, chi2 per equation or measured channel) before each round and after the last correction."""
    if "channels_tested" in rounds[0]:  # partial measurements: the channels' innovations
        stages = [
            (f"before round {r['round']}", {t["channel"]: t["chi2_per_dof"] for t in r["channels_tested"]})
            for r in rounds
        ]
        last = rounds[-1]["correction"]
        return stages + ([("after the last correction", last["channels_after"])] if last else [])
    stages = [
        (
            f"before round {r['round']} ({r['window_steps']}-step windows)",
            {e["state"]: e["chi2_per_dof"] for e in r["equations"]},
        )
        for r in rounds
    ]
    last = rounds[-1]["correction"]
    return stages + ([("after the last correction", last["chi2_after"])] if last else [])


def plot_discovery(findings: Mapping, gap: pd.DataFrame) -> plt.Figure:
    """Left: chi-square per degree of freedom of each equation (or, on partial measurements, of
    each measured channel's innovations) before each round and after the last correction
    (1 = noise).  Right: median held-out error per window for each model and the noise floor."""
    fig, (left, right) = plt.subplots(1, 2, figsize=(13, 4.6), gridspec_kw={"width_ratios": [1.3, 1]})
    stages = _stages(findings["rounds"])
    names = list(stages[0][1])
    width = 0.8 / len(stages)
    positions = np.arange(len(names))
    for i, (label, chi2) in enumerate(stages):
        left.bar(positions + i * width, [chi2[s] for s in names], width, label=label)
    left.axhline(1.0, color="black", lw=0.8, ls="--")
    what = "innovation" if "channels_tested" in findings["rounds"][0] else "residual"
    left.set(
        yscale="log", xticks=positions + 0.4 - width / 2, xticklabels=names, ylabel=f"{what} chi2 / dof (1 = noise)"
    )
    left.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.1), ncol=len(stages), frameon=False)
    left.set_title(f"{findings['case']}: named {', '.join(findings['named']) or 'nothing'}", fontsize=10)
    windows = list(findings["gap"]["noise_floor"])
    table = gap.pivot(index="window", columns="model", values="error").loc[windows]
    models = [m for m in GAP_MODELS if m in table.columns]
    table[models].plot.bar(ax=right, rot=0, width=0.8, color=[GAP_MODELS[m] for m in models])
    right.plot(
        range(len(windows)),
        [findings["gap"]["noise_floor"][w] for w in windows],
        "k_",
        ms=30,
        mew=2,
        label="noise floor",
    )
    right.set(yscale="log", ylabel="median held-out error (coded AN-RFMSE)", xlabel="window")
    right.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=len(models) + 1, frameon=False)
    fig.tight_layout()
    return fig
