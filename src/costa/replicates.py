"""Blow-up counts, median errors and the paper's claims across replicates of the experiment.

A replicate is one whole run with its own data, initialisation and shuffling seeds.
The tables take the per-replicate tables stacked with a ``replicate`` column.
Intervals are percentile bootstrap intervals of the mean over replicates: each
resample draws the replicates with replacement and, within each drawn replicate,
its independent units (instances; trajectories for the PBM, as in
:mod:`costa.summary`), so they cover both the seeds of a run and the instances
within one.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from .claims import LIKELY_REASON, evaluate_claims
from .paper import paper_blowups, paper_median_error
from .seeds import numpy_generator
from .summary import bootstrap_groups, resampling_units

__all__ = ["aggregate_table", "claim_verdicts", "per_replicate_table", "replicate_claims"]

KEYS = ["model_type", "window"]


def per_replicate_table(summaries: pd.DataFrame, definition: str = "coded") -> pd.DataFrame:
    """replicate, model_type, window, rollouts, blowups and median (AN-RFMSE, blow-ups excluded) of each replicate."""
    part = summaries[summaries["definition"] == definition]
    return part[["replicate", *KEYS, "rollouts", "blowups", "median"]].reset_index(drop=True)


def _interval(values: np.ndarray, confidence: float, method: str = "linear") -> tuple[float, float]:
    alpha = (1 - confidence) / 2
    if np.isnan(values).all():
        return np.nan, np.nan
    return tuple(float(np.nanquantile(values, q, method=method)) for q in (alpha, 1 - alpha))


def _two_level_bootstrap(part: pd.DataFrame, resamples: int, rng: np.random.Generator):
    """(mean blow-up counts, mean medians) over replicates for ``resamples`` two-level resamples.

    Each replicate's units are resampled ``resamples`` times; an outer resample draws
    the replicates and, for each drawn one, one of its inner resamples at random.
    """
    inner = [bootstrap_groups(*resampling_units(r)[1:], resamples, rng) for _, r in part.groupby("replicate")]
    counts, medians = (np.stack(values) for values in zip(*inner, strict=True))
    n = len(inner)
    chosen, drawn = rng.integers(0, n, (resamples, n)), rng.integers(0, resamples, (resamples, n))
    medians = medians[chosen, drawn]
    kept = np.isfinite(medians).any(axis=1)  # a resample whose replicates all blew up has no median
    mean_medians = np.full(resamples, np.nan)
    mean_medians[kept] = np.nanmean(medians[kept], axis=1)
    return counts[chosen, drawn].mean(axis=1), mean_medians


def aggregate_table(
    summaries: pd.DataFrame,
    metrics: pd.DataFrame,
    resamples: int = 2000,
    confidence: float = 0.95,
    seed: int = 0,
    definition: str = "coded",
) -> pd.DataFrame:
    """One row per model type and window: the spread over replicates, intervals and the paper's values.

    ``summaries`` are the replicates' summary tables (:func:`costa.summary.summary_table`),
    ``metrics`` their per-rollout tables, both with a ``replicate`` column. Columns:
    model_type, window, replicates, rollouts (per replicate), blowups_{min,max,mean,sd},
    blowups_low/high (interval of the mean count per replicate), median_{min,max,mean,sd}
    and median_low/high (of each replicate's median AN-RFMSE), paper_blowups, out_of, paper_median.
    """
    per_replicate = per_replicate_table(summaries, definition)
    metrics = metrics[metrics["definition"] == definition]
    rows = []
    for index, ((model, window), part) in enumerate(metrics.groupby(KEYS, sort=False)):
        values = per_replicate[(per_replicate["model_type"] == model) & (per_replicate["window"] == window)]
        counts, medians = _two_level_bootstrap(part, resamples, numpy_generator(seed, 0, "replicates", index))
        row = {"model_type": model, "window": window, "replicates": len(values), "rollouts": values["rollouts"].max()}
        for column, resampled in (("blowups", counts), ("median", medians)):
            v = values[column]
            row |= {
                f"{column}_min": v.min(),
                f"{column}_max": v.max(),
                f"{column}_mean": v.mean(),
                f"{column}_sd": v.std(),
            }
            row[f"{column}_low"], row[f"{column}_high"] = _interval(resampled, confidence)
        rows.append(row)
    return (
        pd.DataFrame(rows).merge(paper_blowups(), on=KEYS, how="left").merge(paper_median_error(), on=KEYS, how="left")
    )


def replicate_claims(summaries: pd.DataFrame) -> pd.DataFrame:
    """:func:`costa.claims.evaluate_claims` on each replicate's summary: its rows with a replicate column."""
    return pd.concat(
        [evaluate_claims(summary).assign(replicate=replicate) for replicate, summary in summaries.groupby("replicate")],
        ignore_index=True,
    )[["replicate", "key", "claim", "holds", "effect", "evidence"]]


def _conclusion(holds_in: int, replicates: int) -> str:
    if replicates == 1:
        return "a single run: it cannot tell how often the claim holds with other seeds"
    if holds_in == replicates:
        return "survives: holds in every replicate"
    if holds_in == 0:
        return "does not survive: fails in every replicate"
    return f"not settled: holds in only {holds_in} of {replicates} replicates, so the outcome depends on the seeds"


def claim_verdicts(
    claims: pd.DataFrame, resamples: int = 2000, confidence: float = 0.95, seed: int = 0
) -> pd.DataFrame:
    """One row per claim from the per-replicate verdicts of :func:`replicate_claims`.

    Columns: key, claim, replicates, holds_in, verdict ("holds in k of N replicates"),
    conclusion (survives / does not survive / not settled), held and effects (per replicate, in
    replicate order), effect_median, effect_min, effect_max, effect_low/high (bootstrap
    interval over replicates of the median effect; effects may be infinite) and the
    likely reason where the claim fails in some replicate.
    """
    rows = []
    for index, (key, part) in enumerate(claims.sort_values("replicate").groupby("key", sort=False)):
        n, k = len(part), int(part["holds"].sum())
        effects = part["effect"].to_numpy(dtype=np.float64)
        rng = numpy_generator(seed, 0, "replicates/claims", index)
        medians = np.median(effects[rng.integers(0, n, (resamples, n))], axis=1)
        low, high = _interval(medians, confidence, method="inverted_cdf")  # no interpolation between infinities
        rows.append(
            {
                "key": key,
                "claim": part["claim"].iloc[0],
                "replicates": n,
                "holds_in": k,
                "verdict": f"holds in {k} of {n} replicate{'s' if n > 1 else ''}",
                "conclusion": _conclusion(k, n),
                "held": ", ".join(part["holds"].map({True: "yes", False: "no"})),
                "effects": ", ".join(f"{e:.3g}" for e in effects),
                "effect_median": float(np.median(effects)),
                "effect_min": float(effects.min()),
                "effect_max": float(effects.max()),
                "effect_low": low,
                "effect_high": high,
                "likely_reason": LIKELY_REASON[key] if k < n else "",
            }
        )
    return pd.DataFrame(rows)
