"""Rolling-forecast errors and blow-ups, as the authors coded them and as the paper prints them.

With sigma_i the training set's standard deviation of state i:

- coded (``model_evaluation.py``): e_k = mean_i |xhat_k,i - x_k,i| / sigma_i; a
  non-finite e_k counts as 10.  Windows are disjoint ([0, 100), [100, 2500),
  [2500, 5000)); a rollout blows up in a window if max e_k > 3 there; its
  AN-RFMSE is the mean of e_k over the window.
- printed (paper, eq. 15): s_k = mean_i ((xhat_k,i - x_k,i) / sigma_i)^2, averaged
  over [0, n) for the horizons n = 100, 2500, 5000; a blow-up if s at the final
  step n - 1 exceeds 3.  Non-finite values count as 10 here too.

The AN-RFMSE of a blown-up rollout is kept in the tables (flagged); the paper's
figures leave it out.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .variables import STATES

__all__ = [
    "EvaluationSettings",
    "metrics_table",
    "per_state_table",
    "per_step_error",
    "printed_metrics",
    "state_scale",
    "window_metrics",
    "windows_from_fractions",
]


@dataclass(frozen=True)
class EvaluationSettings:
    """Windows (coded), horizons (printed), threshold and the value of a non-finite error."""

    windows: Mapping[str, tuple[int, int]]
    horizons: Mapping[str, int]
    blowup_threshold: float = 3.0
    nonfinite_error: float = 10.0

    @classmethod
    def from_config(cls, evaluation: Mapping) -> EvaluationSettings:
        return cls(
            windows={k: tuple(v) for k, v in evaluation["windows"].items()},
            horizons=dict(evaluation["horizons"]),
            blowup_threshold=float(evaluation["blowup_threshold"]),
            nonfinite_error=float(evaluation["nonfinite_error"]),
        )

    def check(self, steps: int) -> None:
        """Raise ``ValueError`` naming the window or horizon that does not fit ``steps``."""
        for name, (start, stop) in self.windows.items():
            if not 0 <= start < stop <= steps:
                raise ValueError(
                    f"evaluation.windows.{name} = [{start}, {stop}) does not fit trajectories of {steps} steps"
                )
        for name, n in self.horizons.items():
            if not 0 < n <= steps:
                raise ValueError(f"evaluation.horizons.{name} = {n} does not fit trajectories of {steps} steps")


def windows_from_fractions(fractions: Mapping[str, Sequence[float]], steps: int) -> dict[str, tuple[int, int]]:
    """Disjoint windows [start, stop) in steps from fractions of a trajectory's length ``steps``.

    A bound f becomes round(f * steps); the paper's windows are the fractions
    [0, 0.02), [0.02, 0.5), [0.5, 1] of 5000 steps.  Raises ``ValueError`` naming a
    window that is empty at this length.
    """
    windows = {}
    for name, (low, high) in fractions.items():
        start, stop = round(low * steps), round(high * steps)
        if not 0 <= start < stop <= steps:
            raise ValueError(
                f"window {name!r} = [{low:g}, {high:g}) of {steps} steps is [{start}, {stop}): empty or outside the data"
            )
        windows[name] = (start, stop)
    return windows


def state_scale(x_train: np.ndarray) -> np.ndarray:
    """sigma_i (8,): the unbiased std of each state over every training sample."""
    return x_train.reshape(-1, 8).std(axis=0, ddof=1)


def per_step_error(
    x_hat: np.ndarray, x_true: np.ndarray, scale: np.ndarray, kind: str = "absolute", nonfinite: float = 10.0
) -> np.ndarray:
    """e_k (..., K): the state-averaged normalised error of each step; non-finite -> ``nonfinite``.

    ``kind`` "absolute" is the coded |.| / sigma, "squared" the printed (. / sigma)^2.
    """
    if kind not in ("absolute", "squared"):
        raise ValueError(f"unknown error kind {kind!r}; use 'absolute' or 'squared'")
    with np.errstate(all="ignore"):
        normalised = (x_hat - x_true) / scale
        per_state = np.abs(normalised) if kind == "absolute" else np.square(normalised)
        error = per_state.mean(axis=-1)
    return np.where(np.isfinite(error), error, nonfinite)


def window_metrics(error: np.ndarray, windows: Mapping[str, tuple[int, int]], threshold: float) -> dict:
    """Coded metrics: per window, (mean of e_k, max of e_k > threshold), each (...,)."""
    return {
        name: (error[..., start:stop].mean(axis=-1), error[..., start:stop].max(axis=-1) > threshold)
        for name, (start, stop) in windows.items()
    }


def printed_metrics(error: np.ndarray, horizons: Mapping[str, int], threshold: float) -> dict:
    """Printed metrics: per horizon n, (mean of s_k over [0, n), s_{n-1} > threshold)."""
    return {name: (error[..., :n].mean(axis=-1), error[..., n - 1] > threshold) for name, n in horizons.items()}


def metrics_table(
    model: str, x_hat: np.ndarray, x_true: np.ndarray, scale: np.ndarray, settings: EvaluationSettings
) -> pd.DataFrame:
    """Tidy metrics of forecasts x_hat (E, T, K, 8) of true trajectories x_true (T, K, 8).

    Columns: model_type, instance, trajectory, window, definition (coded|printed),
    error (AN-RFMSE), blown_up.
    """
    frames = []
    for definition, kind, compute, windows in (
        ("coded", "absolute", window_metrics, settings.windows),
        ("printed", "squared", printed_metrics, settings.horizons),
    ):
        error = per_step_error(x_hat, x_true, scale, kind, settings.nonfinite_error)
        for window, (value, blown) in compute(error, windows, settings.blowup_threshold).items():
            frames.append(_tidy(model, window=window, definition=definition, error=value, blown_up=blown))
    return pd.concat(frames, ignore_index=True)


def per_state_table(
    model: str, x_hat: np.ndarray, x_true: np.ndarray, scale: np.ndarray, settings: EvaluationSettings
) -> pd.DataFrame:
    """Mean |xhat_i - x_i| / sigma_i per state and coded window (non-finite -> the sentinel).

    Columns: model_type, instance, trajectory, window, state, error.
    """
    with np.errstate(all="ignore"):
        normalised = np.abs((x_hat - x_true) / scale)
    normalised = np.where(np.isfinite(normalised), normalised, settings.nonfinite_error)
    frames = []
    for window, (start, stop) in settings.windows.items():
        means = normalised[..., start:stop, :].mean(axis=-2)  # (E, T, 8)
        states = np.broadcast_to(np.asarray(STATES), means.shape)
        frames.append(_tidy(model, window=window, state=states, error=means))
    return pd.concat(frames, ignore_index=True)


def _tidy(model: str, **columns) -> pd.DataFrame:
    """A tidy frame of per-rollout values: model_type, instance and trajectory (the first two
    axes of the array columns), then ``columns`` (arrays raveled, scalars repeated)."""
    shape = next(np.shape(v) for v in columns.values() if np.ndim(v))
    instance, trajectory = np.indices(shape)[:2]
    frame = {
        "model_type": model,
        "instance": instance.ravel().astype(np.int32),
        "trajectory": trajectory.ravel().astype(np.int32),
    }
    frame.update({name: np.ravel(v) if np.ndim(v) else v for name, v in columns.items()})
    return pd.DataFrame(frame)
