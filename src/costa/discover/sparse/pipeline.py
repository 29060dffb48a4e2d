"""A discovery run on partial, sparse measurements: from tables to rounds and the gap.

The tables follow the data contract of :mod:`costa.data` (any channel may be absent or
sampled at some steps only).  Channels sampled at every step get their noise from the
data; a channel sampled less often needs its sensor's noise declared.  The gap is
measured on the held-out trajectories' measured channels: each model is rolled out
from the state it estimates from the first ``start_steps`` samples (on a controlled cell,
again each day from the samples then), and scored against what was measured after, beside
the noise floor of the same procedure.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from ...data import TrajectoryDataError, measured_trajectories
from ...metrics import EvaluationSettings
from ...physics import CellModel
from ..core.outcome import Outcome, compared_models
from ..core.settings import DiscoverySettings
from .filter.search import discover_sparse, fit_share, screen_round
from .gap import measured_gap, measured_noise_floor
from .observations import Observations, channel_noise
from .observed import START_SEARCH_S, start_is_searched
from .rounds import SparseRound
from .shooting.round import decide_by_shooting, fit_by_shooting, screen_by_shooting
from .split import (
    read_fits,
    read_screen,
    read_shot_fits,
    read_shot_screen,
    write_fits,
    write_screen,
    write_shot_fits,
    write_shot_screen,
)

__all__ = ["fit_first_round", "observations", "run_sparse_discovery", "screen_first_round"]


def observations(table: pd.DataFrame, declared_noise: Mapping[str, float], source: str) -> Observations:
    """The measured channels of a checked table, with each channel's noise std."""
    measured = measured_trajectories(table)
    try:
        noise = channel_noise(measured.values, measured.channels, declared_noise, measured.inputs)
    except ValueError as error:
        raise TrajectoryDataError(f"{source}: {error}") from None
    return Observations(y=measured.values, u=measured.inputs, channels=measured.channels, noise=noise, dt=measured.dt)


def _estimation_windows(
    evaluation: EvaluationSettings, held: Observations, source: str
) -> tuple[EvaluationSettings, int]:
    """The gap's windows and the samples a rollout's start is estimated from: the first window's.

    Where the first state is searched (a pot line's record), the start needs the first hand
    samples (:data:`.observed.START_SEARCH_S`): the first window is widened to hold them, and a
    window that began inside it begins after it, so that no window but the first is scored on
    samples that placed the start (plant: 0-8 h, 8-24 h, 24-48 h for 0-58 min, 58 min-24 h, 24-48 h)."""
    start_steps = min(stop for _, stop in evaluation.windows.values())
    if not start_is_searched(held.y, held.channels):
        return evaluation, start_steps
    needed = min(held.y.shape[1], max(start_steps, round(START_SEARCH_S / held.dt)))
    windows = {  # the first window ends at ``needed``; a later one starts there at the earliest
        name: (low, needed) if high == start_steps else (max(low, needed) if low > 0 else low, high)
        for name, (low, high) in evaluation.windows.items()
    }
    if any(low >= high for low, high in windows.values()):
        raise TrajectoryDataError(
            f"{source}: trajectories of {held.y.shape[1]} samples are too short for the gap's windows {dict(evaluation.windows)} "
            f"after the first {needed} samples, which place each held-out cell's first state; record longer cells"
        )
    return replace(evaluation, windows=windows, horizons={w: stop for w, (_, stop) in windows.items()}), needed


def checked_observations(
    train: pd.DataFrame, declared_noise: Mapping[str, float], source: str, settings: DiscoverySettings
) -> Observations:
    """The training table's observations, refused with one clear error where too short to test."""
    obs = observations(train, declared_noise, source)
    needed = obs.settling_steps + 4 * settings.window + 1
    if obs.y.shape[1] < needed:
        settling = (
            f" after the first {obs.settling_steps}, where the filter settles from a searched start"
            if obs.settling_steps
            else ""
        )
        raise TrajectoryDataError(
            f"{source}: trajectories of {obs.y.shape[1]} samples are too short; discovery needs at least "
            f"{needed} (4 windows of discovery.window_steps = {settings.window}{settling})"
        )
    return obs


def screen_first_round(
    train: pd.DataFrame, start: CellModel, settings: DiscoverySettings, declared_noise: Mapping[str, float],
    source: str, path: str | Path,
) -> None:  # fmt: skip
    """The first round's screen (:func:`.filter.search.screen_round`, or :func:`.shooting.round.screen_by_shooting`
    on the shooting route, ``settings.shooting_cells`` > 0), written to ``path`` for the fit jobs and the gather
    (:mod:`.split`)."""
    obs = checked_observations(train, declared_noise, source, settings).with_start(start)
    if settings.shooting_cells:
        write_shot_screen(screen_by_shooting(start, obs, settings), obs.start, path)
        return
    screen = screen_round(start, obs, settings, np.random.default_rng(settings.seed), named=())
    write_screen(screen, obs.start, path)


def fit_first_round(
    train: pd.DataFrame, start: CellModel, settings: DiscoverySettings, declared_noise: Mapping[str, float],
    source: str, screen_path: str | Path, job: int, jobs: int, path: str | Path,
) -> None:  # fmt: skip
    """Job ``job`` of ``jobs``: fit the screen's candidates job, job + jobs, ... and write them to ``path``."""
    obs = checked_observations(train, declared_noise, source, settings)
    share = slice(job, None, jobs)
    if settings.shooting_cells:
        screen, _ = read_shot_screen(screen_path, start)
        write_shot_fits(
            fit_by_shooting(start, screen, obs, settings, share), range(len(screen.candidates))[share], path
        )
        return
    screen, searched = read_screen(screen_path, start)
    obs = replace(obs, start=searched)
    fits = fit_share(screen, start, obs=obs, settings=settings, rich=False, share=share, first=True)
    write_fits(fits, range(len(screen.candidates))[share], path)


def _shooting_round(
    start: CellModel, obs: Observations, settings: DiscoverySettings, first_round: tuple | None
) -> SparseRound:
    """The round :mod:`.shooting.round` decides, from the jobs' records where given; every cell's first
    state searched under ``start`` (by the screen's job, where given)."""
    if first_round is None:
        obs = obs.with_start(start)
        screen = screen_by_shooting(start, obs, settings)
        fits = fit_by_shooting(start, screen, obs, settings, slice(None))
    else:
        screen, searched = read_shot_screen(first_round[0], start)
        obs, fits = replace(obs, start=searched), read_shot_fits(first_round[1])
    return decide_by_shooting(start, screen, fits, obs, settings)


def run_sparse_discovery(
    train: pd.DataFrame,
    held_out: pd.DataFrame,
    start: CellModel,
    settings: DiscoverySettings,
    evaluation: EvaluationSettings,
    declared_noise: Mapping[str, float],
    source: str,
    rng: np.random.Generator,
    first_round: tuple[str | Path, Sequence[str | Path]] | None = None,
    restart_s: float | None = None,
) -> Outcome:
    """Discover on ``train``; the gap of the starting and corrected models on ``held_out``.

    ``evaluation`` gives the gap's windows; the state a rollout starts from is estimated
    from the first window's samples, and every ``restart_s`` [s] again from the samples then
    (:func:`.gap.forecast_pieces`; None: one rollout over the whole record).  ``first_round``:
    the paths of the first round's screen and fit records, where separate jobs made them
    (:func:`screen_first_round`, :func:`fit_first_round`); the findings are the same.
    """
    obs = checked_observations(train, declared_noise, source, settings)
    held = observations(held_out, declared_noise, source)
    if held.channels != obs.channels:
        raise TrajectoryDataError(
            f"{source}: the held-out trajectories measure {list(held.channels)}, the others {list(obs.channels)}"
        )
    evaluation, start_steps = _estimation_windows(evaluation, held, source)  # checked before the search runs
    started = time.perf_counter()
    if settings.shooting_cells:
        rounds = [_shooting_round(start, obs, settings, first_round)]
    elif first_round is None:
        obs = obs.with_start(start)
        rounds = discover_sparse(start, obs, settings)
    else:
        screen, searched = read_screen(first_round[0], start)
        obs = replace(obs, start=searched)
        rounds = discover_sparse(start, obs, settings, (screen, read_fits(first_round[1], start, obs)))
    seconds = time.perf_counter() - started
    models = compared_models(rounds, start)
    corrected = models.get("corrected model", start)
    scale = np.nanstd(obs.y.reshape(-1, len(obs.channels)), axis=0, ddof=1)
    restart = round(restart_s / held.dt) if restart_s else None
    gap, per_channel = measured_gap(
        models, held, scale=scale, settings=evaluation, start_steps=start_steps, restart_steps=restart
    )
    floor = measured_noise_floor(
        corrected, held, scale=scale, settings=evaluation, start_steps=start_steps, rng=rng, restart_steps=restart
    )
    return Outcome(
        measured="partial", rounds=rounds, channels=obs.channels, noise=obs.noise, corrected=corrected, gap=gap,
        per_state=per_channel, floor=floor, seconds=seconds, windows=dict(evaluation.windows), dt=obs.dt,
        start_steps=start_steps, restart_steps=restart,
    )  # fmt: skip
