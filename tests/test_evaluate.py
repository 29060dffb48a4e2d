"""Rollouts, metrics (both definitions), summary intervals and claim verdicts."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import torch

from costa.claims import evaluate_claims
from costa.ensemble import MLPEnsemble
from costa.forecast import rollout_networks, rollout_physics
from costa.metrics import (
    EvaluationSettings,
    metrics_table,
    per_state_table,
    per_step_error,
    printed_metrics,
    state_scale,
    window_metrics,
)
from costa.models import NetworkModel
from costa.summary import all_blown_up, summary_table
from costa.train import ModelType, Normalisation

SCALE = np.array([1.0, 2.0, 4.0, 8.0, 1.0, 1.0, 1.0, 1.0])


def test_true_model_rolled_forward_reproduces_its_data(smoke_train, model, settings):
    x, u = smoke_train
    rk4 = rollout_physics(model, x, u, settings.dt, copied=1, method="rk4")
    np.testing.assert_allclose(rk4, x, rtol=1e-12)
    euler = rollout_physics(model, x, u, settings.dt, copied=1, method="euler")
    relative = np.abs(euler - x) / state_scale(x)
    assert relative.max() < 0.05  # Euler at dt = 10 s drifts slowly from RK4


def test_network_rollout_with_a_zero_network_is_euler_on_the_pbm(smoke_train, model, settings):
    """CoSTA with a network that outputs 0 is the PBM integrated by forward Euler from sample 3."""
    x, u = smoke_train
    zero = MLPEnsemble([torch.zeros(2, 13, 4), torch.zeros(2, 4, 8)], [torch.zeros(2, 1, 4), torch.zeros(2, 1, 8)])
    normalisation = Normalisation(np.zeros(13), np.ones(13), np.zeros(8), np.ones(8))
    costa = NetworkModel(ModelType("costa_zero", "costa", 0.0), zero, normalisation, model, {})
    forecasts = rollout_networks(costa, x, u, settings.dt, copied=3)
    assert forecasts.shape == (2, *x.shape)
    np.testing.assert_array_equal(forecasts[:, :, :3], np.broadcast_to(x[:, :3], (2, *x[:, :3].shape)))
    expected = rollout_physics(model, x[:, 2:], u[:, 2:], settings.dt, copied=1, method="euler")
    np.testing.assert_allclose(forecasts[0, :, 2:], expected, rtol=1e-12)
    np.testing.assert_array_equal(forecasts[0], forecasts[1])


def test_diverging_rollouts_do_not_stop_the_others(smoke_train, model, settings):
    x, u = smoke_train
    peaks = np.sort(x[:, :, 5].max(axis=1))
    limit = (peaks[-1] + peaks[-2]) / 2  # only the hottest trajectory gets above it
    hot = x[:, :, 5].max(axis=1) > limit
    conductivity = model.parts["bath_conductivity"]
    broken = model.with_part(
        "bath_conductivity",
        conductivity.renamed("NaN when hot", lambda v, k, q: v.xp.where(v.x6 > limit, np.nan, conductivity(v, k, q))),
    )
    forecasts = rollout_physics(broken, x, u, settings.dt)
    error = per_step_error(forecasts, x, SCALE)
    assert not np.isfinite(forecasts[hot]).all()  # the hottest trajectory diverges ...
    assert np.isfinite(error).all() and error[hot].max() == 10.0  # ... and is scored, not raised
    assert np.isfinite(forecasts[~hot]).all()  # the others are untouched


def test_per_step_errors_by_hand():
    truth = np.zeros((1, 4, 8))
    forecast = truth.copy()
    forecast[0, 1, 0] = 1.0  # 1 sigma in x1 -> 1/8
    forecast[0, 2, 3] = -16.0  # 2 sigma in x4 -> |.| 2/8, squared 4/8
    forecast[0, 3, 5] = np.nan
    np.testing.assert_allclose(per_step_error(forecast, truth, SCALE, "absolute"), [[0, 1 / 8, 2 / 8, 10]])
    np.testing.assert_allclose(per_step_error(forecast, truth, SCALE, "squared"), [[0, 1 / 8, 4 / 8, 10]])
    forecast[0, 3, 5] = np.inf
    assert per_step_error(forecast, truth, SCALE, "squared")[0, 3] == 10
    forecast[0, 3, 5] = -np.inf
    assert per_step_error(forecast, truth, SCALE, nonfinite=7.0)[0, 3] == 7.0
    with pytest.raises(ValueError, match="unknown error kind 'cubic'"):
        per_step_error(forecast, truth, SCALE, "cubic")


def test_coded_windows_are_disjoint_and_blow_up_is_strictly_above_threshold():
    error = np.array([[0.0, 1.0, 3.0, 2.0, 3.0000001, 0.0]])
    result = window_metrics(error, {"a": (0, 3), "b": (3, 6)}, threshold=3.0)
    assert result["a"][0][0] == pytest.approx(4 / 3) and not result["a"][1][0]  # max exactly 3: not blown
    assert result["b"][0][0] == pytest.approx(5.0000001 / 3) and result["b"][1][0]


def test_printed_horizons_are_cumulative_and_judge_the_final_step():
    error = np.array([[0.0, 9.0, 0.0, 0.0, 4.0, 10.0]])
    result = printed_metrics(error, {"a": 4, "b": 5, "c": 6}, threshold=3.0)
    assert (
        result["a"][0][0] == pytest.approx(9 / 4) and not result["a"][1][0]
    )  # a spike before the end is not a blow-up
    assert result["b"][0][0] == pytest.approx(13 / 5) and result["b"][1][0]
    assert result["c"][0][0] == pytest.approx(23 / 6) and result["c"][1][0]  # a NaN's sentinel at the end blows up


def test_metrics_and_per_state_tables(rng):
    truth = rng.normal(size=(3, 50, 8))
    forecasts = truth + rng.normal(scale=0.01, size=(2, 3, 50, 8))
    forecasts[1, 2, 30:] = np.nan
    settings = EvaluationSettings({"early": (0, 20), "late": (20, 50)}, {"early": 20, "late": 50})
    table = metrics_table("m", forecasts, truth, SCALE, settings)
    assert len(table) == 2 * 3 * 2 * 2
    assert list(table.columns) == ["model_type", "instance", "trajectory", "window", "definition", "error", "blown_up"]
    blown = table[table.blown_up]
    assert set(zip(blown.instance, blown.trajectory, blown.window, strict=True)) == {(1, 2, "late")}
    per_state = per_state_table("m", forecasts, truth, SCALE, settings)
    assert len(per_state) == 2 * 3 * 2 * 8
    late = per_state[(per_state.instance == 1) & (per_state.trajectory == 2) & (per_state.window == "late")]
    assert late.error.min() > 5  # 20 of 30 steps at the sentinel 10


def _metrics(counts: dict[str, list[int]], trajectories: int = 10) -> pd.DataFrame:
    """Hand-made coded metrics: counts[model] = blow-ups per instance in one window 'long'."""
    rows = []
    for model, per_instance in counts.items():
        for instance, blown in enumerate(per_instance):
            for trajectory in range(trajectories):
                rows.append((model, instance, trajectory, "long", "coded", 0.1 * (instance + 1), trajectory < blown))
    return pd.DataFrame(
        rows, columns=["model_type", "instance", "trajectory", "window", "definition", "error", "blown_up"]
    )


def test_summary_counts_medians_and_intervals():
    summary = summary_table(_metrics({"ddm_dense": [2, 4, 6], "pbm": [3]}), resamples=500, seed=1)
    ddm = summary[summary.model_type == "ddm_dense"].iloc[0]
    assert (ddm.rollouts, ddm.instances, ddm.blowups, ddm.interval_unit) == (30, 3, 12, "instance")
    assert 6 <= ddm.blowups_low <= 12 <= ddm.blowups_high <= 18
    # not blown: 8 rollouts at 0.1, 6 at 0.2, 4 at 0.3 -> median 0.2
    assert ddm["median"] == pytest.approx(0.2) and ddm.median_low <= 0.2 <= ddm.median_high
    pbm = summary[summary.model_type == "pbm"].iloc[0]
    assert (pbm.blowups, pbm.interval_unit) == (3, "trajectory")


def test_a_type_whose_rollouts_all_blew_up_is_warned_about_and_no_other():
    summary = summary_table(_metrics({"ddm_dense": [10, 10], "costa_dense": [10, 9], "pbm": [0]}), resamples=50, seed=1)
    warnings = all_blown_up(summary)
    assert len(warnings) == 1
    assert "every one of the 20 rollouts of ddm_dense blew up in the long window" in warnings[0]


def _summary(medians: dict, blowups: dict) -> pd.DataFrame:
    rows = [
        {"model_type": m, "window": w, "definition": "coded", "median": medians[m][i], "blowups": blowups[m][i]}
        for m in medians
        for i, w in enumerate(("short", "medium", "long"))
    ]
    return pd.DataFrame(rows)


def test_claim_verdicts_on_hand_made_summaries():
    medians = {
        "ddm_dense": (0.02, 0.1, 0.3), "ddm_sparse": (0.02, 0.09, 0.3),
        "costa_dense": (0.005, 0.04, 0.1), "costa_sparse": (0.005, 0.03, 0.05), "pbm": (0.2, 0.25, 0.2),
    }  # fmt: skip
    paper_like = {
        "ddm_dense": (0, 120, 275), "ddm_sparse": (0, 11, 90), "costa_dense": (0, 9, 52),
        "costa_sparse": (0, 0, 34), "pbm": (0, 0, 0),
    }  # fmt: skip
    verdicts = evaluate_claims(_summary(medians, paper_like)).set_index("key")
    assert verdicts.holds.all(), verdicts.evidence.to_dict()
    assert (verdicts.likely_reason == "").all()
    other = dict(paper_like, ddm_sparse=(0, 40, 200), costa_sparse=(0, 1, 30), pbm=(0, 1, 2))
    worse = dict(medians, costa_sparse=(0.03, 0.03, 0.05))
    verdicts = evaluate_claims(_summary(worse, other)).set_index("key")
    assert not verdicts.loc["l1_cuts_ddm_blowups", "holds"]  # 200 / 275 = 0.73 > 0.5
    assert verdicts.loc["l1_cuts_ddm_blowups", "effect"] == pytest.approx(200 / 275)
    assert not verdicts.loc["sparse_costa_stable", "holds"]  # one medium blow-up
    assert not verdicts.loc["pbm_never_blows_up", "holds"] and verdicts.loc["pbm_never_blows_up", "effect"] == 3
    assert not verdicts.loc["costa_more_accurate", "holds"]  # short: 0.03 > 0.02
    assert verdicts.loc["networks_beat_pbm", "holds"]
    assert "reference runs" in verdicts.loc["l1_cuts_ddm_blowups", "likely_reason"]
