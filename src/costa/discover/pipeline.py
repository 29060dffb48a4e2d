"""A discovery run from data to findings: load or simulate, check, discover, measure the gap."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from .. import seeds
from ..data import TrajectoryDataError, incomplete_states, load_trajectories
from ..metrics import EvaluationSettings, windows_from_fractions
from ..observe import observe
from ..physics import CellModel, model_from_config
from ..sensors import measure, sensor_sets_from_config
from ..simulate import SimulationSettings, simulate_set
from .cases import HiddenEffectCase
from .core.settings import DiscoverySettings
from .full_state.pipeline import DiscoveryResult, run_full_state_discovery
from .sparse.pipeline import PartialResult, run_partial_discovery
from .unshipped import find_case

__all__ = [
    "case_tables",
    "gap_settings",
    "run_discovery",
    "split_held_out",
    "starting_model",
]


def starting_model(config: Mapping, name: str) -> CellModel:
    """'full' (the true model of the config's physics) or 'ablated' (the paper's PBM)."""
    full, ablated = model_from_config(config["physics"])
    models = {"full": full, "ablated": ablated}
    if name not in models:
        raise ValueError(f"unknown starting model {name!r}; known: {sorted(models)}")
    return models[name]


def case_tables(
    config: Mapping, case: str | HiddenEffectCase, sensors: str = "full"
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Training and held-out tables of a case (a shipped or unshipped one by name), simulated with its true model
    and measured by the sensor set ``sensors`` of ``discovery.sensor_sets``.

    A sensor that leaves its noise open gets the case's level: that fraction of its channel's
    std over the data set (the full set is then every state with the case's noise).
    """
    case = find_case(case) if isinstance(case, str) else case
    discovery = config["discovery"]
    sensor_set = sensor_sets_from_config(discovery["sensor_sets"])[sensors]
    settings = SimulationSettings.from_config(config["simulation"])
    settings = replace(settings, steps=sensor_set.steps(settings.dt, settings.steps))
    true, _ = case.models(model_from_config(config["physics"])[0])
    tables = []
    counts = (
        ("train", sensor_set.trajectories or discovery["trajectories"]),
        ("held_out", sensor_set.held_out_trajectories or discovery["held_out_trajectories"]),
    )
    for split, count in counts:
        stream = f"discovery/{case.name}/{split}"
        trajectories, _ = simulate_set(true, settings, count, config["seed"], 0, stream)
        x, u = trajectories.x, trajectories.u
        values = observe(true, x, u, sensor_set.channels).reshape(-1, len(sensor_set.channels))
        default = dict(zip(sensor_set.channels, case.noise * values.std(axis=0), strict=True))
        noise = f"{stream}/noise" if sensors == "full" else f"{stream}/sensors/{sensors}"
        rng = seeds.numpy_generator(config["seed"], 0, noise)
        tables.append(measure(true, x, u, settings.dt, sensor_set, rng, default))
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


#: the paper's windows [0, 100), [100, 2500), [2500, 5000) as fractions of a trajectory's length
PAPER_FRACTIONS = {"short": (0.0, 0.02), "medium": (0.02, 0.5), "long": (0.5, 1.0)}


def gap_settings(config: Mapping, name: str, steps: int) -> EvaluationSettings:
    """How the gap on held-out trajectories of ``steps`` samples is scored.

    A shipped case simulated at ``simulation.steps`` is scored in the config's evaluation
    windows (the paper's at 5000 steps).  Your own data are scored in
    ``discovery.user_data.gap_windows``, fractions of the held-out length, and data of any
    other length (a sensor set's longer trajectories) in the same fractions as the paper's
    windows (the first 2 %, 2-50 %, 50-100 %).
    """
    evaluation = EvaluationSettings.from_config(config["evaluation"])
    user = config["discovery"]["user_data"]
    if user and user["name"] == name:
        fractions, key = user["gap_windows"], "discovery.user_data.gap_windows"
    elif steps == config["simulation"]["steps"]:
        evaluation.check(steps)
        return evaluation
    else:
        fractions, key = PAPER_FRACTIONS, "the paper's window fractions"
    try:
        windows = windows_from_fractions(fractions, steps)
    except ValueError as error:
        raise TrajectoryDataError(f"{key}: {error}; make the window wider") from None
    return replace(evaluation, windows=windows, horizons={w: stop for w, (_, stop) in windows.items()})


def settings_from_config(config: Mapping) -> DiscoverySettings:
    d = config["discovery"]
    return DiscoverySettings(
        window=d["window_steps"], z_threshold=d["z_threshold"], min_excess=d["min_excess"], max_terms=d["max_terms"],
        min_gain=d["min_bic_gain"], min_explained=d["min_explained"], max_rounds=d["max_rounds"],
        bootstrap=d["bootstrap"],
    )  # fmt: skip


def run_discovery(
    config: Mapping,
    train: pd.DataFrame,
    held_out: pd.DataFrame,
    start: CellModel,
    name: str,
    source: str,
    declared_noise: Mapping[str, float] | None = None,
) -> DiscoveryResult | PartialResult:
    """Discover on ``train``, then measure the gap of the starting and corrected models on ``held_out``.

    Tables with every state at every step take the weak-form route (:mod:`.full_state`); any
    other table (states missing or sampled now and then, outputs such as the cell voltage) the
    estimator's (:mod:`.sparse`), with ``declared_noise`` for channels too sparse to estimate it.
    ``name`` keys the random streams; ``source`` names the data in error messages.
    """
    settings = replace(settings_from_config(config), seed=seeds.stream(config["seed"], 0, f"discovery/{name}/search"))
    floor_rng = seeds.numpy_generator(config["seed"], 0, f"discovery/{name}/floor")
    if incomplete_states(train) or incomplete_states(held_out):
        evaluation = gap_settings(config, name, int(held_out.groupby("trajectory").size().iloc[0]))
        return run_partial_discovery(
            train, held_out, start, settings, evaluation, declared_noise or {}, source, floor_rng
        )
    return run_full_state_discovery(
        train, held_out, start, settings, lambda steps: gap_settings(config, name, steps), source, floor_rng
    )
