"""The paper's claims (SPEC section 7) as checks on a summary table of one run.

Each check returns whether the claim holds, the effect size it rests on, and a
sentence of evidence.  Thresholds for the paper's words are stated here once:
"sharply" = at most half, "about half" = at most 0.6 of the comparison.  All
checks use the coded metric (the one the paper's figures were made with).

The claims are about blow-ups out of 1000 rollouts of 5000 steps: a smaller run
(the smoke config, say) cannot assess them, and its verdicts say so
(:func:`below_paper_size`) instead of "not reproduced".
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

__all__ = ["CLAIMS", "NOT_ASSESSED", "PAPER_SIZE", "Claim", "LIKELY_REASON", "below_paper_size", "evaluate_claims"]

SHARPLY = 0.5
ABOUT_HALF = 0.6

#: The paper's experiment: (section, key) -> the size its claims were made at.
PAPER_SIZE = {
    ("simulation", "steps"): 5000,
    ("simulation", "train_trajectories"): 40,
    ("simulation", "test_trajectories"): 100,
    ("training", "instances"): 10,
    ("training", "epochs"): 100,
}
PAPER_WINDOWS = {"short": [0, 100], "medium": [100, 2500], "long": [2500, 5000]}
NOT_ASSESSED = "not assessed at this size"


def below_paper_size(config: Mapping[str, Any]) -> str:
    """What makes a run smaller than the paper's experiment ("" if nothing does)."""
    smaller = [
        f"{section}.{key} = {config[section][key]} (paper {size})"
        for (section, key), size in PAPER_SIZE.items()
        if config[section][key] < size
    ]
    windows = {name: list(bounds) for name, bounds in config["evaluation"]["windows"].items()}
    if windows != PAPER_WINDOWS:
        smaller.append(f"evaluation.windows = {windows} (paper {PAPER_WINDOWS})")
    return "; ".join(smaller)


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
    return sorted(m for m in summary.model_type.unique() if m.startswith(prefix))


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


def evaluate_claims(summary: pd.DataFrame, below_size: str = "") -> pd.DataFrame:
    """One row per claim: key, claim, holds, effect, evidence, verdict, and the likely reason where it fails.

    ``verdict`` is "reproduced" or "not reproduced", or :data:`NOT_ASSESSED` for a run
    smaller than the paper's (``below_size``, from :func:`below_paper_size`, says how;
    it then stands in the likely-reason column).  ``holds`` is computed either way.
    """
    rows = []
    for claim in CLAIMS:
        holds, effect, evidence = claim.check(summary)
        if below_size:
            verdict, reason = NOT_ASSESSED, f"the run is smaller than the paper's: {below_size}"
        else:
            verdict, reason = ("reproduced", "") if holds else ("not reproduced", LIKELY_REASON[claim.key])
        rows.append(
            {
                "key": claim.key,
                "claim": claim.text,
                "holds": bool(holds),
                "effect": float(effect),
                "evidence": evidence,
                "verdict": verdict,
                "likely_reason": reason,
            }
        )
    return pd.DataFrame(rows)
