"""Blow-up counts and median AN-RFMSE per model type and window, with bootstrap intervals.

Intervals resample the independent units of a model type: its instances (each
instance's 100 rollouts stay together, since they share one set of weights), or,
for a type with a single instance such as the PBM, its trajectories.  The interval
is the percentile interval of the statistic over the resamples.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["all_blown_up", "bootstrap_groups", "resampling_units", "summary_table", "with_interval"]


def resampling_units(part: pd.DataFrame) -> tuple[str, list[np.ndarray], list[np.ndarray]]:
    """The independent units of one model type's rollouts in one window.

    Returns the unit ("instance", or "trajectory" for a type with one instance) and,
    per unit, its errors and blow-up flags.
    """
    unit = "instance" if part["instance"].nunique() > 1 else "trajectory"
    grouped = [g for _, g in part.groupby(unit, sort=True)]
    return unit, [g["error"].to_numpy() for g in grouped], [g["blown_up"].to_numpy(dtype=bool) for g in grouped]


def bootstrap_groups(groups: list[np.ndarray], blown: list[np.ndarray], resamples: int, rng: np.random.Generator):
    """(blow-up counts, medians) over ``resamples`` resamples of the groups."""
    n = len(groups)
    counts = np.empty(resamples)
    medians = np.empty(resamples)
    for r in range(resamples):
        chosen = rng.integers(0, n, n)
        counts[r] = sum(blown[i].sum() for i in chosen)
        kept = np.concatenate([groups[i][~blown[i]] for i in chosen])
        medians[r] = np.median(kept) if kept.size else np.nan
    return counts, medians


def summary_table(
    metrics: pd.DataFrame, resamples: int = 2000, confidence: float = 0.95, seed: int = 0
) -> pd.DataFrame:
    """One row per model type, window and definition.

    Columns: rollouts, instances, blowups, blowups_low, blowups_high, blowup_rate,
    median (AN-RFMSE of the rollouts that did not blow up), median_low, median_high,
    not_blown (how many rollouts the median is over).
    """
    rows = []
    alpha = (1 - confidence) / 2
    keys = ["model_type", "window", "definition"]
    for (model, window, definition), part in metrics.groupby(keys, sort=False):
        rng = np.random.default_rng([seed, len(rows)])
        unit, errors, blown = resampling_units(part)
        counts, medians = bootstrap_groups(errors, blown, resamples, rng)
        kept = part.loc[~part["blown_up"], "error"]
        rows.append(
            {
                "model_type": model,
                "window": window,
                "definition": definition,
                "rollouts": len(part),
                "instances": part["instance"].nunique(),
                "blowups": int(part["blown_up"].sum()),
                "blowups_low": float(np.quantile(counts, alpha)),
                "blowups_high": float(np.quantile(counts, 1 - alpha)),
                "blowup_rate": float(part["blown_up"].mean()),
                "median": float(kept.median()) if len(kept) else np.nan,
                "median_low": float(np.nanquantile(medians, alpha)) if np.isfinite(medians).any() else np.nan,
                "median_high": float(np.nanquantile(medians, 1 - alpha)) if np.isfinite(medians).any() else np.nan,
                "not_blown": len(kept),
                "interval_unit": unit,
            }
        )
    return pd.DataFrame(rows)


def all_blown_up(summary: pd.DataFrame) -> list[str]:
    """One warning for each model type whose rollouts all blew up in some window of
    ``summary`` (one definition's rows): its models are broken, not merely poor."""
    whole = summary[summary["blowups"] == summary["rollouts"]]
    return [
        f"every one of the {int(part['rollouts'].iloc[0])} rollouts of {model} blew up in the "
        f"{', '.join(part['window'])} window(s): its models are probably broken (a non-finite or diverged "
        f"training; see logs/train_{model}.log), so its numbers below are not a result"
        for model, part in whole.groupby("model_type", sort=False)
    ]


def with_interval(value: float, low: float, high: float, spec: str = ".3g") -> str:
    """'value [low, high]', or "—" where there is no value (no rollout left to take a median of)."""
    if pd.isna(value):
        return "—"
    return f"{value:{spec}} [{low:{spec}}, {high:{spec}}]"
