"""A discovery run from data to findings: load or simulate, check, discover, measure the gap."""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from .. import seeds
from ..data import TrajectoryDataError, arrays, load_trajectories, to_table
from ..metrics import EvaluationSettings, state_scale
from ..physics import CellModel, model_from_config
from ..simulate import SimulationSettings, simulate_set
from ..variables import INPUTS
from .cases import HiddenEffectCase, add_noise
from .gap import gap_tables, noise_floor
from .search import DiscoverySettings, Round, discover
from .unshipped import find_case
from .weak_form import estimate_noise

__all__ = ["DiscoveryData", "DiscoveryResult", "case_tables", "run_discovery", "split_held_out", "starting_model"]


@dataclass(frozen=True)
class DiscoveryData:
    """Measured trajectories to learn from, held-out ones to measure the gap on, and dt [s]."""

    x: np.ndarray
    u: np.ndarray
    x_held_out: np.ndarray
    u_held_out: np.ndarray
    dt: float


@dataclass
class DiscoveryResult:
    rounds: list[Round]
    noise: np.ndarray
    corrected: CellModel
    gap: pd.DataFrame
    per_state: pd.DataFrame
    floor: dict[str, float]
    seconds: float


def starting_model(config: Mapping, name: str) -> CellModel:
    """'full' (the true model of the config's physics) or 'ablated' (the paper's PBM)."""
    full, ablated = model_from_config(config["physics"])
    models = {"full": full, "ablated": ablated}
    if name not in models:
        raise ValueError(f"unknown starting model {name!r}; known: {sorted(models)}")
    return models[name]


def case_tables(config: Mapping, case: str | HiddenEffectCase) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Noisy training and held-out tables of a case (a shipped or unshipped one by name), simulated with its true model."""
    case = find_case(case) if isinstance(case, str) else case
    discovery = config["discovery"]
    settings = SimulationSettings.from_config(config["simulation"])
    true, _ = case.models(model_from_config(config["physics"])[0])
    tables = []
    for split, count in (("train", discovery["trajectories"]), ("held_out", discovery["held_out_trajectories"])):
        stream = f"discovery/{case.name}/{split}"
        trajectories, _ = simulate_set(true, settings, count, config["seed"], 0, stream)
        noisy = add_noise(trajectories.x, case.noise, seeds.numpy_generator(config["seed"], 0, f"{stream}/noise"))
        tables.append(to_table(noisy, trajectories.u, settings.dt))
    return tables[0], tables[1]


def split_held_out(path: str | Path, fraction: float) -> tuple[pd.DataFrame, pd.DataFrame]:
    """A user's table split by trajectory: the last ``fraction`` of them are held out."""
    table = load_trajectories(path)
    ids = np.sort(table["trajectory"].unique())
    if len(ids) < 2:
        raise TrajectoryDataError(
            f"{path}: discovery needs at least 2 trajectories (one is held out to measure the gap), found {len(ids)}"
        )
    held = ids[len(ids) - max(1, int(round(fraction * len(ids)))) :]
    return table[~table["trajectory"].isin(held)], table[table["trajectory"].isin(held)]


def _check_suitable(x: np.ndarray, u: np.ndarray, window: int, source: str) -> None:
    """One clear error if the data cannot support discovery."""
    if x.shape[1] < 4 * window + 1:
        raise TrajectoryDataError(
            f"{source}: trajectories of {x.shape[1]} samples are too short; discovery needs at least "
            f"{4 * window + 1} (4 windows of discovery.window_steps = {window})"
        )
    constant = [name for i, name in enumerate(INPUTS) if np.ptp(u[..., i]) == 0]
    if constant:
        raise TrajectoryDataError(
            f"{source}: inputs {constant} do not vary; discovery needs excited inputs to tell effects apart"
        )


def _data(train: pd.DataFrame, held_out: pd.DataFrame, source: str, window: int) -> DiscoveryData:
    x, u = arrays(train)
    xh, uh = arrays(held_out)
    _check_suitable(x, u, window, source)
    steps = np.diff(train["time_s"].to_numpy()[:2])
    return DiscoveryData(x, u, xh, uh, float(steps[0]))


def settings_from_config(config: Mapping) -> DiscoverySettings:
    d = config["discovery"]
    return DiscoverySettings(
        window=d["window_steps"], z_threshold=d["z_threshold"], min_excess=d["min_excess"], max_terms=d["max_terms"],
        min_gain=d["min_bic_gain"], min_explained=d["min_explained"], max_rounds=d["max_rounds"],
        bootstrap=d["bootstrap"],
    )  # fmt: skip


def run_discovery(
    config: Mapping, train: pd.DataFrame, held_out: pd.DataFrame, start: CellModel, name: str, source: str
) -> DiscoveryResult:
    """Discover on ``train``, then measure the gap of the starting and corrected models on ``held_out``.

    ``name`` keys the random streams; ``source`` names the data in error messages.
    """
    settings = replace(settings_from_config(config), seed=seeds.stream(config["seed"], 0, f"discovery/{name}/search"))
    data = _data(train, held_out, source, settings.window)
    started = time.perf_counter()
    rounds, noise = discover(start, data.x, data.u, data.dt, settings)
    seconds = time.perf_counter() - started
    corrected = next((r.chosen.corrected for r in reversed(rounds) if r.chosen is not None), start)
    evaluation = EvaluationSettings.from_config(config["evaluation"])
    evaluation.check(data.x_held_out.shape[1])
    scale = state_scale(data.x)
    models = (
        {"starting model": start, "corrected model": corrected} if corrected is not start else {"starting model": start}
    )
    gap, per_state = gap_tables(models, data.x_held_out, data.u_held_out, data.dt, scale, evaluation)
    rng = seeds.numpy_generator(config["seed"], 0, f"discovery/{name}/floor")
    # the held-out trajectories' own noise: their sensors (or their noise level) may differ
    held_out_noise = estimate_noise(data.x_held_out)
    floor = noise_floor(corrected, data.x_held_out, data.u_held_out, data.dt, held_out_noise, scale, evaluation, rng)
    return DiscoveryResult(rounds, noise, corrected, gap, per_state, floor, seconds)
