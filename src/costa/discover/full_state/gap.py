"""The gap between a model and held-out trajectories of every state, before and after a correction."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from ...forecast import rollout_physics
from ...metrics import EvaluationSettings, per_state_table, per_step_error, window_metrics
from ...physics import CellModel

__all__ = ["gap_tables", "noise_floor"]


def gap_tables(
    models: Mapping[str, CellModel | np.ndarray],
    x: np.ndarray,
    u: np.ndarray,
    dt: float,
    scale: np.ndarray,
    settings: EvaluationSettings,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Rollouts of each model (or given forecasts (E, T, K, 8)) on held-out trajectories x, u.

    Returns (per window: model, window, error (median over rollouts of the coded
    AN-RFMSE), mean, blowups, rollouts), and the per-state table of
    :func:`costa.metrics.per_state_table` with a ``model`` column.
    """
    rows, states = [], []
    for name, model in models.items():
        forecasts = model if isinstance(model, np.ndarray) else rollout_physics(model, x, u, dt)[None]
        error = per_step_error(forecasts, x, scale, "absolute", settings.nonfinite_error)
        for window, (value, blown) in window_metrics(error, settings.windows, settings.blowup_threshold).items():
            rows.append(
                {"model": name, "window": window, "error": float(np.median(value)), "mean": float(np.mean(value)),
                 "blowups": int(blown.sum()), "rollouts": int(blown.size)}
            )  # fmt: skip
        states.append(per_state_table(name, forecasts, x, scale, settings).rename(columns={"model_type": "model"}))
    return pd.DataFrame(rows), pd.concat(states, ignore_index=True)


def noise_floor(
    model: CellModel,
    x: np.ndarray,
    u: np.ndarray,
    dt: float,
    noise: np.ndarray,
    scale: np.ndarray,
    settings: EvaluationSettings,
    rng: np.random.Generator,
    draws: int = 4,
) -> dict[str, float]:
    """The error a perfect model would still show against noisy held-out data, per window.

    Estimated by a parametric bootstrap: ``model`` plays the truth from the measured
    start, measurement noise of the estimated size ``noise`` (8,) is added to it, and a
    rollout from that noisy start is scored against the noisy data; the median over
    rollouts, averaged over ``draws`` noise draws.
    """
    truth = rollout_physics(model, x, u, dt)
    measured = np.stack([truth + rng.normal(size=truth.shape) * noise for _ in range(draws)])
    # the draws' rollouts side by side, one batch: each trajectory's rollout is its own
    forecasts = rollout_physics(model, measured.reshape(-1, *truth.shape[1:]), np.tile(u, (draws, 1, 1)), dt)
    medians = []
    for draw, forecast in zip(measured, forecasts.reshape(measured.shape), strict=True):
        error = per_step_error(forecast[None], draw, scale, "absolute", settings.nonfinite_error)
        medians.append(
            {
                w: np.median(v)
                for w, (v, _) in window_metrics(error, settings.windows, settings.blowup_threshold).items()
            }
        )
    return {w: float(np.mean([m[w] for m in medians])) for w in settings.windows}
