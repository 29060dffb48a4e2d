"""The gap between a model and held-out measurements, before and after a correction."""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Mapping

import numpy as np
import pandas as pd

from ..forecast import rollout_physics
from ..metrics import EvaluationSettings, per_state_table, per_step_error, window_metrics
from ..observe import observe
from ..physics import CellModel
from .observed import estimate_states
from .partial import Observations

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
    medians = []
    for _ in range(draws):
        measured = truth + rng.normal(size=truth.shape) * noise
        forecasts = rollout_physics(model, measured, u, dt)
        error = per_step_error(forecasts[None], measured, scale, "absolute", settings.nonfinite_error)
        medians.append(
            {
                w: np.median(v)
                for w, (v, _) in window_metrics(error, settings.windows, settings.blowup_threshold).items()
            }
        )
    return {w: float(np.mean([m[w] for m in medians])) for w in settings.windows}


def measured_channel_error(
    forecast: np.ndarray, y: np.ndarray, scale: np.ndarray, nonfinite: float = 10.0
) -> np.ndarray:
    """e_k (n, K): the coded error on measured channels only, the mean over the channels sampled at
    step k of |forecast - y| / scale (C,); NaN at a step where nothing was sampled; a non-finite
    forecast of a sampled channel counts ``nonfinite``."""
    sampled = np.isfinite(y)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a step without a sample has no error
        per_channel = np.abs(forecast - y) / scale
        per_channel = np.where(sampled, np.where(np.isfinite(per_channel), per_channel, nonfinite), np.nan)
        return np.nanmean(per_channel, axis=-1)


def _rollout_from_estimate(model: CellModel, obs: Observations, start_steps: int) -> np.ndarray:
    """Channels (n, K, C) of ``model`` rolled out from its smoothed estimate of the first state,
    made from the first ``start_steps`` samples only (where the first state is searched, it is
    searched on those samples too, under ``model``: nothing the rollout is scored on after them
    places its start, and each model starts where it would place the cell itself)."""
    early = dataclasses.replace(obs, y=obs.y[:, :start_steps], u=obs.u[:, :start_steps]).with_start(model)
    estimated = estimate_states(model, early.y, early.u, early.channels, early.noise, early.dt, start=early.start)
    first = estimated.mean[:, :1]
    start = np.concatenate([first, np.zeros((obs.y.shape[0], obs.y.shape[1] - 1, 8))], axis=1)
    with np.errstate(all="ignore"):
        return observe(model, rollout_physics(model, start, obs.u, obs.dt), obs.u, obs.channels)


def measured_gap(
    models: Mapping[str, CellModel],
    obs: Observations,
    scale: np.ndarray,
    settings: EvaluationSettings,
    start_steps: int,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Each model's gap on held-out partial measurements ``obs``: rolled out from the state it
    estimates from the first ``start_steps`` samples, scored on the measured channels per window.

    Returns (per window: model, window, error (median over trajectories of the mean error),
    mean, blowups (as coded), rollouts) and (per channel: model, window, channel, error).
    """
    rows, per_channel = [], []
    for name, model in models.items():
        forecast = _rollout_from_estimate(model, obs, start_steps)
        rows += _window_rows(name, measured_channel_error(forecast, obs.y, scale), settings)
        for c, channel in enumerate(obs.channels):
            error = measured_channel_error(forecast[..., c : c + 1], obs.y[..., c : c + 1], scale[c : c + 1])
            per_channel += [{**row, "channel": channel} for row in _window_rows(name, error, settings)]
    columns = ["model", "window", "channel", "error"]
    return pd.DataFrame(rows), pd.DataFrame(per_channel)[columns]


def _window_rows(name: str, error: np.ndarray, settings: EvaluationSettings) -> list[dict]:
    """Per window: the median over trajectories of each one's mean error over its sampled steps."""
    rows = []
    for window, (start, stop) in settings.windows.items():
        part = error[:, start:stop]
        with warnings.catch_warnings():  # a trajectory without a sample in a window has no error there
            warnings.simplefilter("ignore", RuntimeWarning)
            value = np.nanmean(part, axis=-1)
            worst = np.nanmax(np.where(np.isnan(part), -np.inf, part), axis=-1)
            median, mean = float(np.nanmedian(value)), float(np.nanmean(value))
        rows.append(
            {"model": name, "window": window, "error": median, "mean": mean,
             "blowups": int((worst > settings.blowup_threshold).sum()), "rollouts": int(np.isfinite(value).sum())}
        )  # fmt: skip
    return rows


def measured_noise_floor(
    model: CellModel,
    obs: Observations,
    scale: np.ndarray,
    settings: EvaluationSettings,
    start_steps: int,
    rng: np.random.Generator,
) -> dict[str, float]:
    """The gap a perfect model would still show on these sensors: ``model`` plays the truth from
    its own estimated start, its channels are sampled where ``obs`` was, with the sensors' noise, and the
    same procedure (estimate the start, roll out, score) runs on that synthetic record."""
    truth = _rollout_from_estimate(model, obs, start_steps)
    measured = np.where(np.isfinite(obs.y), truth + rng.normal(size=truth.shape) * obs.noise, np.nan)
    forecast = _rollout_from_estimate(model, dataclasses.replace(obs, y=measured), start_steps)
    rows = _window_rows("floor", measured_channel_error(forecast, measured, scale), settings)
    return {row["window"]: row["error"] for row in rows}
