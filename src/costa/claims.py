"""The paper's claims (SPEC section 7) as checks on a summary table of one run.

Each check returns whether the claim holds, the effect size it rests on, and a
sentence of evidence.  Thresholds for the paper's words are stated here once:
"sharply" = at most half, "about half" = at most 0.6 of the comparison.  All
checks use the coded metric (the one the paper's figures were made with).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

__all__ = ["CLAIMS", "Claim", "LIKELY_REASON", "evaluate_claims"]

SHARPLY = 0.5
ABOUT_HALF = 0.6


@dataclass(frozen=True)
class Claim:
    key: str
    text: str
    check: Callable[[pd.DataFrame], tuple[bool, float, str]]


def _value(summary: pd.DataFrame, model: str, window: str, column: str) -> float:
    row = summary[(summary.model_type == model) & (summary.window == window) & (summary.definition == "coded")]
    if row.empty:
        raise KeyError(f"no coded summary row for {model} / {window}")
    return float(row[column].iloc[0])


def _types(summary: pd.DataFrame, prefix: str) -> list[str]:
    """The paper's dense and sparse types of one kind (other types, e.g. config/beyond.yaml's, are not its claims)."""
    return sorted(m for m in summary.model_type.unique() if m in (f"{prefix}_dense", f"{prefix}_sparse"))


def _windows(summary: pd.DataFrame) -> list[str]:
    return list(dict.fromkeys(summary.loc[summary.definition == "coded", "window"]))


def _costa_more_accurate(s: pd.DataFrame):
    ratios = {
        w: max(_value(s, c, w, "median") for c in _types(s, "costa"))
        / min(_value(s, d, w, "median") for d in _types(s, "ddm"))
        for w in _windows(s)
    }
    worst = max(ratios, key=ratios.get)
    return (
        all(r < 1 for r in ratios.values()),
        ratios[worst],
        "largest CoSTA median / smallest DDM median per window: "
        + ", ".join(f"{w} {r:.2f}" for w, r in ratios.items()),
    )


def _networks_beat_pbm(s: pd.DataFrame):
    windows = [w for w in _windows(s) if w in ("short", "medium")]
    networks = _types(s, "ddm") + _types(s, "costa")
    ratios = {w: max(_value(s, m, w, "median") for m in networks) / _value(s, "pbm", w, "median") for w in windows}
    return (
        all(r < 1 for r in ratios.values()),
        max(ratios.values()),
        "largest network median / PBM median: " + ", ".join(f"{w} {r:.2f}" for w, r in ratios.items()),
    )


def _l1_cuts_ddm_blowups(s: pd.DataFrame):
    dense, sparse = _value(s, "ddm_dense", "long", "blowups"), _value(s, "ddm_sparse", "long", "blowups")
    ratio = sparse / dense if dense else np.inf
    return (
        ratio <= SHARPLY,
        ratio,
        f"long-window blow-ups: DDM sparse {sparse:.0f} vs DDM dense {dense:.0f} (ratio {ratio:.2f}; 'sharply' = at most {SHARPLY})",
    )


def _sparse_costa_stable(s: pd.DataFrame):
    early = sum(_value(s, "costa_sparse", w, "blowups") for w in ("short", "medium"))
    costa, ddm = _value(s, "costa_sparse", "long", "blowups"), _value(s, "ddm_sparse", "long", "blowups")
    ratio = costa / ddm if ddm else (0.0 if costa == 0 else np.inf)
    return (
        early == 0 and ratio <= ABOUT_HALF,
        ratio,
        f"CoSTA sparse: {early:.0f} short/medium blow-ups; long {costa:.0f} vs DDM sparse {ddm:.0f} "
        f"(ratio {ratio:.2f}; 'about half' = at most {ABOUT_HALF})",
    )


def _pbm_never_blows_up(s: pd.DataFrame):
    counts = {w: _value(s, "pbm", w, "blowups") for w in _windows(s)}
    total = sum(counts.values())
    return total == 0, total, "PBM blow-ups: " + ", ".join(f"{w} {c:.0f}" for w, c in counts.items())


CLAIMS = (
    Claim("costa_more_accurate", "CoSTA is more accurate than DDM at every horizon", _costa_more_accurate),
    Claim("networks_beat_pbm", "DDM and CoSTA beat the PBM in the short and medium term", _networks_beat_pbm),
    Claim("l1_cuts_ddm_blowups", "l1 regularisation cuts DDM blow-ups sharply", _l1_cuts_ddm_blowups),
    Claim(
        "sparse_costa_stable",
        "sparse CoSTA has no short/medium blow-ups and about half the long-term blow-ups of sparse DDM",
        _sparse_costa_stable,
    ),
    Claim("pbm_never_blows_up", "the PBM never blows up", _pbm_never_blows_up),
)


#: What the evidence says about a claim that does not hold in a run (SPEC section 7's
#: three reference runs of the authors' settings with other seeds).
LIKELY_REASON = {
    "costa_more_accurate": "CoSTA's accuracy advantage is large in every reference run; a failure points to a bug.",
    "networks_beat_pbm": "Every reference run has the networks well below the PBM early on; a failure points to a bug.",
    "l1_cuts_ddm_blowups": (
        "The effect of l1 on DDM blow-ups varies strongly with the seeds: the long-window ratio sparse/dense "
        "was 124/322 = 0.39, 184/229 = 0.80 and 310/359 = 0.86 in the reference runs, against the paper's "
        "90/275 = 0.33. One run cannot settle it; see the replicates."
    ),
    "sparse_costa_stable": (
        "Sparse CoSTA stays far below sparse DDM in the long window in every reference run (ratios 0.44, 0.28, "
        "0.06), but a handful of short/medium blow-ups out of 1000 occur depending on the seeds."
    ),
    "pbm_never_blows_up": (
        "The ablated PBM can drive the alumina fraction across the g3 = 1 anode-effect singularity of the "
        "bubble voltage; whether the state then runs away depends on rounding. The reference runs saw 5, 0 "
        "and 3 of 100."
    ),
}


def evaluate_claims(summary: pd.DataFrame) -> pd.DataFrame:
    """One row per claim: key, claim, holds, effect, evidence, and the likely reason where it fails."""
    rows = []
    for claim in CLAIMS:
        holds, effect, evidence = claim.check(summary)
        rows.append(
            {
                "key": claim.key,
                "claim": claim.text,
                "holds": bool(holds),
                "effect": float(effect),
                "evidence": evidence,
                "likely_reason": "" if holds else LIKELY_REASON[claim.key],
            }
        )
    return pd.DataFrame(rows)
