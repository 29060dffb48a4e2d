"""A run smaller than the paper's cannot assess the paper's claims, and says so."""

from __future__ import annotations

import pandas as pd

from costa.claims import CLAIMS, NOT_ASSESSED, below_paper_size, evaluate_claims


def _summary() -> pd.DataFrame:
    """A coded summary in which every claim fails: networks worse than the PBM, every model blowing up."""
    rows = [
        {"model_type": m, "window": w, "definition": "coded", "median": 1.0 if m != "pbm" else 0.1, "blowups": 5}
        for m in ("ddm_dense", "ddm_sparse", "costa_dense", "costa_sparse", "pbm")
        for w in ("short", "medium", "long")
    ]
    return pd.DataFrame(rows)


def test_the_paper_size_is_assessed_and_the_smoke_size_is_not(default_config, smoke_config):
    assert below_paper_size(default_config) == ""
    reason = below_paper_size(smoke_config)
    assert "simulation.steps = 400 (paper 5000)" in reason and "training.instances = 2 (paper 10)" in reason
    assert "evaluation.windows" in reason


def test_a_tiny_run_reports_not_assessed_instead_of_failures(smoke_config):
    claims = evaluate_claims(_summary(), below_paper_size(smoke_config))
    assert (claims.verdict == NOT_ASSESSED).all() and len(claims) == len(CLAIMS)
    assert claims.likely_reason.str.startswith("the run is smaller than the paper's: simulation.steps = 400").all()
    assert not claims.likely_reason.str.contains("points to a bug").any()
    full = evaluate_claims(_summary())
    assert (full.verdict == "not reproduced").all() and full.likely_reason.str.len().gt(0).all()
