"""A discovery run on full-state data (every state at every step): from tables to rounds and the gap."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ...data import TrajectoryDataError, arrays, time_step
from ...metrics import EvaluationSettings, state_scale
from ...physics import CellModel
from ..core.noise import estimate_noise
from ..core.outcome import Outcome, compared_models
from ..core.settings import DiscoverySettings
from .gap import gap_tables, noise_floor
from .search import discover

__all__ = ["DiscoveryData", "run_full_state_discovery"]


@dataclass(frozen=True)
class DiscoveryData:
    """Measured trajectories to learn from, held-out ones to measure the gap on, and dt [s]."""

    x: np.ndarray
    u: np.ndarray
    x_held_out: np.ndarray
    u_held_out: np.ndarray
    dt: float


def _check_suitable(x: np.ndarray, window: int, source: str) -> None:
    """One clear error if the data cannot support discovery."""
    if x.shape[1] < 4 * window + 1:
        raise TrajectoryDataError(
            f"{source}: trajectories of {x.shape[1]} samples are too short; discovery needs at least "
            f"{4 * window + 1} (4 windows of discovery.window_steps = {window})"
        )


def _data(train: pd.DataFrame, held_out: pd.DataFrame, source: str, window: int) -> DiscoveryData:
    x, u = arrays(train)
    xh, uh = arrays(held_out)
    _check_suitable(x, window, source)
    return DiscoveryData(x=x, u=u, x_held_out=xh, u_held_out=uh, dt=time_step(train))


def run_full_state_discovery(
    train: pd.DataFrame,
    held_out: pd.DataFrame,
    start: CellModel,
    settings: DiscoverySettings,
    evaluation_for: Callable[[int], EvaluationSettings],
    source: str,
    floor_rng: np.random.Generator,
) -> Outcome:
    """Discover on ``train`` in weak form, then measure the gap of the starting and corrected models
    on ``held_out``.

    ``evaluation_for(steps)`` gives how the gap on held-out trajectories of ``steps`` samples is
    scored (asked once the rounds have run); ``source`` names the data in error messages;
    ``floor_rng`` draws the noise floor's noise.
    """
    data = _data(train, held_out, source, settings.window)
    started = time.perf_counter()
    rounds, noise = discover(start, data.x, data.u, data.dt, settings)
    seconds = time.perf_counter() - started
    models = compared_models(rounds, start)
    corrected = models.get("corrected model", start)
    evaluation = evaluation_for(data.x_held_out.shape[1])
    scale = state_scale(data.x)
    gap, per_state = gap_tables(
        models, data.x_held_out, u=data.u_held_out, dt=data.dt, scale=scale, settings=evaluation
    )
    # the held-out trajectories' own noise: their sensors (or their noise level) may differ
    held_out_noise = estimate_noise(data.x_held_out)
    floor = noise_floor(
        corrected, data.x_held_out, u=data.u_held_out, dt=data.dt, noise=held_out_noise, scale=scale,
        settings=evaluation, rng=floor_rng,
    )  # fmt: skip
    return Outcome(
        measured="full", rounds=rounds, noise=noise, corrected=corrected, gap=gap, per_state=per_state, floor=floor,
        seconds=seconds, windows=dict(evaluation.windows), dt=data.dt,
    )  # fmt: skip
