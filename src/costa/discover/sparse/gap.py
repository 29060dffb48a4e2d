"""The gap between a model and held-out partial measurements, on the channels that were measured."""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Mapping

import numpy as np
import pandas as pd

from ...compiled import CompiledModel
from ...metrics import EvaluationSettings
from ...physics import CellModel
from .observations import Observations
from .observed import estimate_states

__all__ = ["forecast_pieces", "measured_channel_error", "measured_gap", "measured_noise_floor"]


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
    early = obs.steps(0, start_steps).with_start(model)
    estimated = estimate_states(
        model, early.y, u=early.u, channels=early.channels, noise_std=early.noise, dt=early.dt, start=early.start
    )
    channels, _ = CompiledModel(model, obs.dt, obs.channels, derivatives=False).march(estimated.mean[:, 0], obs.u)
    return channels


def forecast_pieces(steps: int, start_steps: int, restart_steps: int | None) -> list[tuple[int, int, int]]:
    """(begin, end, scored from) of each forecast over a record of ``steps``: one from the first step,
    scored throughout; or, every ``restart_steps``, one that starts from the state estimated on its
    own first ``start_steps`` samples and is scored after them until the next one is (the first
    from its start, as the single one)."""
    if not restart_steps:
        return [(0, steps, 0)]
    begins = range(0, steps - start_steps, restart_steps)
    return [(b, min(steps, b + restart_steps + start_steps), b + start_steps if b else 0) for b in begins]


def _forecast(model: CellModel, obs: Observations, start_steps: int, restart_steps: int | None) -> np.ndarray:
    """Channels (n, K, C) of ``model``'s forecasts, each piece (:func:`forecast_pieces`) where it is scored."""
    forecast = np.full(obs.y.shape, np.nan)
    for begin, end, scored in forecast_pieces(obs.y.shape[1], start_steps, restart_steps):
        piece = _rollout_from_estimate(model, obs.steps(begin, end), start_steps)
        forecast[:, scored:end] = piece[:, scored - begin :]
    return forecast


def measured_gap(
    models: Mapping[str, CellModel],
    obs: Observations,
    scale: np.ndarray,
    settings: EvaluationSettings,
    start_steps: int,
    restart_steps: int | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Each model's gap on held-out partial measurements ``obs``: rolled out from the state it
    estimates from the first ``start_steps`` samples, scored on the measured channels per window;
    ``restart_steps``: a forecast restarted that often from the state it estimates then
    (:func:`forecast_pieces`: a controlled cell's logged feeds replayed open-loop for days drift).

    Returns (per window: model, window, error (median over trajectories of the mean error),
    mean, blowups (as coded), rollouts) and (per channel: model, window, channel, error).
    """
    rows, per_channel = [], []
    for name, model in models.items():
        forecast = _forecast(model, obs, start_steps, restart_steps)
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
    restart_steps: int | None = None,
) -> dict[str, float]:
    """The gap a perfect model would still show on these sensors: ``model`` plays the truth from
    its own estimated start, its channels are sampled where ``obs`` was, with the sensors' noise, and the
    same procedure (estimate the start, roll out, score) runs on that synthetic record; each forecast
    piece (:func:`forecast_pieces`) on its own synthetic record."""
    error = np.full(obs.y.shape[:2], np.nan)
    for begin, end, scored in forecast_pieces(obs.y.shape[1], start_steps, restart_steps):
        piece = obs.steps(begin, end)
        truth = _rollout_from_estimate(model, piece, start_steps)
        measured = np.where(np.isfinite(piece.y), truth + rng.normal(size=truth.shape) * piece.noise, np.nan)
        forecast = _rollout_from_estimate(model, dataclasses.replace(piece, y=measured), start_steps)
        error[:, scored:end] = measured_channel_error(forecast, measured, scale)[:, scored - begin :]
    rows = _window_rows("floor", error, settings)
    return {row["window"]: row["error"] for row in rows}
