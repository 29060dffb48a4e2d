"""Aggregation across replicates and the claims' verdicts, on hand-made tables."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from costa.claims import CLAIMS
from costa.replicates import aggregate_table, claim_verdicts, per_replicate_table, replicate_claims
from costa.summary import summary_table

TYPES = ["ddm_dense", "ddm_sparse", "costa_dense", "costa_sparse", "pbm"]
WINDOWS = ["short", "medium", "long"]


def metrics_table(blown: dict[tuple[str, str], int], instances: int = 2, trajectories: int = 5) -> pd.DataFrame:
    """Rollouts of every type and window whose error grows with the trajectory; the first ``blown[type, window]``
    rollouts (in instance-major order) blew up."""
    rows = []
    for model in TYPES:
        for window in WINDOWS:
            n = 1 if model == "pbm" else instances
            for k, (instance, trajectory) in enumerate(np.ndindex(n, trajectories)):
                is_blown = k < blown.get((model, window), 0)
                error = 10.0 if is_blown else (0.01 if model.startswith("costa") else 0.1) * (1 + trajectory)
                rows.append((model, instance, trajectory, window, "coded", error, is_blown))
    columns = ["model_type", "instance", "trajectory", "window", "definition", "error", "blown_up"]
    return pd.DataFrame(rows, columns=columns)


def stacked(blown_per_replicate: list[dict]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(summaries, metrics) of the replicates, with a replicate column."""
    metrics = [metrics_table(blown).assign(replicate=r) for r, blown in enumerate(blown_per_replicate)]
    summaries = [
        summary_table(m.drop(columns="replicate"), 50, seed=1).assign(replicate=r) for r, m in enumerate(metrics)
    ]
    return pd.concat(summaries, ignore_index=True), pd.concat(metrics, ignore_index=True)


# l1 halves DDM blow-ups ("sharply" = at most 0.5) in replicates 0, 2 and 4 only.
L1_BLOWUPS = [(8, 2), (8, 6), (6, 3), (4, 4), (10, 5)]


@pytest.fixture(scope="module")
def five_replicates():
    return stacked([{("ddm_dense", "long"): d, ("ddm_sparse", "long"): s} for d, s in L1_BLOWUPS])


def test_per_replicate_counts_and_spread(five_replicates):
    summaries, metrics = five_replicates
    per_replicate = per_replicate_table(summaries)
    dense = per_replicate[(per_replicate.model_type == "ddm_dense") & (per_replicate.window == "long")]
    assert dense["blowups"].tolist() == [d for d, _ in L1_BLOWUPS]
    aggregate = aggregate_table(summaries, metrics, resamples=300, seed=3).set_index(["model_type", "window"])
    row = aggregate.loc[("ddm_dense", "long")]
    counts = np.array([d for d, _ in L1_BLOWUPS])
    assert (row.replicates, row.rollouts, row.blowups_min, row.blowups_max) == (5, 10, 4, 10)
    assert row.blowups_mean == pytest.approx(counts.mean()) and row.blowups_sd == pytest.approx(counts.std(ddof=1))
    assert 0 <= row.blowups_low < counts.mean() < row.blowups_high <= 10
    assert row.paper_blowups == 275 and row.paper_median == pytest.approx(0.3)
    # nothing varies across replicates or instances: a degenerate interval at the value
    quiet = aggregate.loc[("costa_sparse", "short")]
    assert quiet.blowups_low == quiet.blowups_high == 0
    assert quiet.median_low == quiet.median_mean == quiet.median_high == pytest.approx(0.03)
    assert len(aggregate) == len(TYPES) * len(WINDOWS)


def test_aggregate_is_reproducible(five_replicates):
    summaries, metrics = five_replicates
    first, second = (aggregate_table(summaries, metrics, resamples=100, seed=3) for _ in range(2))
    pd.testing.assert_frame_equal(first, second)


def test_a_claim_holding_in_three_of_five_replicates_says_so(five_replicates):
    summaries, _ = five_replicates
    claims = replicate_claims(summaries)
    assert len(claims) == 5 * len(CLAIMS)
    verdicts = claim_verdicts(claims, resamples=200, seed=3).set_index("key")
    l1 = verdicts.loc["l1_cuts_ddm_blowups"]
    assert (l1.replicates, l1.holds_in, l1.verdict) == (5, 3, "holds in 3 of 5 replicates")
    assert l1.conclusion.startswith("not settled: holds in only 3 of 5")
    assert l1.held == "yes, no, yes, no, yes" and l1.effects == "0.25, 0.75, 0.5, 1, 0.5"
    assert (l1.effect_median, l1.effect_min, l1.effect_max) == (0.5, 0.25, 1.0)
    assert l1.effect_min <= l1.effect_low <= l1.effect_median <= l1.effect_high <= l1.effect_max
    assert "varies strongly with the seeds" in l1.likely_reason
    pbm = verdicts.loc["pbm_never_blows_up"]
    assert (pbm.verdict, pbm.conclusion, pbm.likely_reason) == (
        "holds in 5 of 5 replicates", "survives: holds in every replicate", ""
    )  # fmt: skip
    assert verdicts.loc["networks_beat_pbm"].conclusion.startswith("does not survive")


def test_one_replicate_is_a_single_run():
    summaries, _ = stacked([{}])
    verdicts = claim_verdicts(replicate_claims(summaries), resamples=50)
    assert (verdicts.verdict.str.endswith("of 1 replicate")).all()
    assert verdicts.conclusion.str.startswith("a single run").all()


def test_infinite_effects_keep_a_finite_interval_end():
    claims = pd.DataFrame(
        {"replicate": range(4), "key": "l1_cuts_ddm_blowups", "claim": "l1", "holds": False,
         "effect": [0.8, np.inf, 0.9, np.inf], "evidence": ""}
    )  # fmt: skip
    verdict = claim_verdicts(claims, resamples=500, seed=1).iloc[0]
    assert verdict.verdict == "holds in 0 of 4 replicates"
    assert verdict.effect_low == 0.8 and verdict.effect_high == np.inf and verdict.effect_max == np.inf
