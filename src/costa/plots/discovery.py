"""A discovery case at a glance: which equations disagree, round by round, and the gap."""

from __future__ import annotations

from collections.abc import Mapping

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from ..variables import STATES

#: the gap's models in reading order, with their colours
GAP_MODELS = {"starting model": "#d62728", "corrected model": "#2ca02c", "CoSTA reference": "#ff7f0e"}


def plot_discovery(findings: Mapping, gap: pd.DataFrame) -> plt.Figure:
    """Left: chi-square per degree of freedom of each equation before each round and after the
    last correction (1 = noise).  Right: median held-out error per window for each model and
    the noise floor."""
    fig, (left, right) = plt.subplots(1, 2, figsize=(13, 4.6), gridspec_kw={"width_ratios": [1.3, 1]})
    rounds = findings["rounds"]
    stages = [(f"before round {r['round']} ({r['window_steps']}-step windows)", r["equations"]) for r in rounds]
    stages = [(label, {e["state"]: e["chi2_per_dof"] for e in equations}) for label, equations in stages]
    if rounds[-1]["named"]:
        stages.append(("after the last correction", rounds[-1]["named"]["chi2_after"]))
    width = 0.8 / len(stages)
    positions = np.arange(len(STATES))
    for i, (label, chi2) in enumerate(stages):
        left.bar(positions + i * width, [chi2[s] for s in STATES], width, label=label)
    left.axhline(1.0, color="black", lw=0.8, ls="--")
    left.set(
        yscale="log", xticks=positions + 0.4 - width / 2, xticklabels=STATES, ylabel="residual chi2 / dof (1 = noise)"
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
