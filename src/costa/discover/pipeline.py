"""A discovery run from data to findings: the glue that reads the config and runs the route.

The starting model, the settings and the gap's windows come from the config; the route (full
state, filter or shooting) from what the record samples (:func:`.route.record_route`).  A user's
own table is split into training and held-out trajectories here too.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
import pandas as pd

from .. import seeds
from ..data import TrajectoryDataError, load_trajectories, time_step
from ..metrics import EvaluationSettings, windows_from_fractions
from ..physics import CellModel, model_from_config
from ..variables import INPUTS
from .core.library import constant_inputs
from .core.naming import settled
from .core.outcome import Outcome
from .core.settings import DiscoverySettings
from .full_state.pipeline import run_full_state_discovery
from .route import Route, record_route
from .sparse.pipeline import run_sparse_discovery

log = logging.getLogger(__name__)

__all__ = [
    "discovery_route",
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


def split_held_out(
    path: str | Path, fraction: float, unlogged: Mapping[str, float] | None = None
) -> tuple[pd.DataFrame, pd.DataFrame, str]:
    """A user's table split into trajectories to learn from and held-out ones, and the split in words.

    Several trajectories: the last ``fraction`` of them (by id) are held out.  One trajectory (one
    pot's record): it is cut by time into ``max(2, round(1 / fraction))`` pieces of equal length (its
    first samples, fewer than the pieces, left out), learned on the first and held out on the last
    ``fraction`` of them.  ``unlogged``: inputs the record lacks, held at their stated values
    (:func:`costa.data.load_trajectories`)."""
    table = load_trajectories(path, unlogged)
    ids = np.sort(table["trajectory"].unique())
    what = f"{len(ids)} trajectories"
    if len(ids) == 1:
        table, what = _cut_by_time(table, max(2, int(round(1 / fraction))), path)
        ids = np.sort(table["trajectory"].unique())
    held = ids[len(ids) - max(1, int(round(fraction * len(ids)))) :]
    if len(ids) == len(held):
        raise TrajectoryDataError(
            f"{path}: held_out_fraction {fraction:g} of {len(ids)} trajectories holds out every one; "
            "discovery needs one or more to learn from"
        )
    how = f"{what}: {len(ids) - len(held)} learned from, the last {len(held)} held out"
    return table[~table["trajectory"].isin(held)], table[table["trajectory"].isin(held)], how


def _cut_by_time(table: pd.DataFrame, pieces: int, path: str | Path) -> tuple[pd.DataFrame, str]:
    """One trajectory (``path``'s) cut into ``pieces`` consecutive trajectories of equal length (ids
    0..pieces-1), and the cut in words."""
    samples = len(table) // pieces
    if samples < 2:
        raise TrajectoryDataError(
            f"{path}: one trajectory of {len(table)} samples cannot be cut into {pieces} to learn from and hold out"
        )
    dropped = len(table) - samples * pieces
    cut = table.iloc[dropped:].reset_index(drop=True)
    cut["trajectory"] = np.repeat(np.arange(pieces), samples)
    cut["step"] = np.tile(np.arange(samples, dtype=np.int32), pieces)
    hours = samples * time_step(table) / 3600
    left_out = f", its first {dropped} samples left out" if dropped else ""
    return cut, f"one trajectory cut by time into {pieces} of {samples} samples ({hours:.3g} h{left_out})"


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


def _record_settings(config: Mapping, name: str) -> Mapping:
    """What data set ``name`` declares of itself: your ``discovery.user_data``, or the sensor set of a
    shipped case under one ("case/sensors"); empty otherwise."""
    user = config["discovery"]["user_data"]
    if user and user["name"] == name:
        return user
    return config["discovery"]["sensor_sets"].get(name.rpartition("/")[2], {}) if "/" in name else {}


def discovery_route(config: Mapping, name: str, tables: Sequence[pd.DataFrame]) -> Route:
    """The route of data set ``name`` from what its ``tables`` (training and held-out) sample, with
    its sensor set's or your ``shooting_cells`` where stated (:func:`.route.record_route`)."""
    return record_route(tables, time_step(tables[0]), _record_settings(config, name).get("shooting_cells"))


def search_settings(config: Mapping, name: str, route: Route) -> DiscoverySettings:
    """How the discovery of data set ``name`` decides on its ``route``, with its own random stream, and
    its sensor set's or your ``min_excess`` where stated."""
    seed = seeds.stream(config["seed"], 0, f"discovery/{name}/search")
    settings = replace(settings_from_config(config), seed=seed, shooting_cells=route.shooting_cells)
    material = _record_settings(config, name).get("min_excess")
    return settings if material is None else replace(settings, min_excess=material)


def gap_restart_s(config: Mapping, name: str) -> float | None:
    """How often [s] the gap's forecasts of data set ``name`` restart from the state estimated then:
    its sensor set's or your ``gap_restart_hours`` (None: one forecast over each held-out record)."""
    hours = _record_settings(config, name).get("gap_restart_hours")
    return 3600.0 * hours if hours else None


def run_discovery(
    config: Mapping,
    train: pd.DataFrame,
    held_out: pd.DataFrame,
    start: CellModel,
    name: str,
    source: str,
    declared_noise: Mapping[str, float] | None = None,
    first_round: tuple[str | Path, Sequence[str | Path]] | None = None,
) -> Outcome:
    """Discover on ``train``, then measure the gap of the starting and corrected models on ``held_out``.

    Tables with every state at every step take the weak-form route (:mod:`.full_state`); any
    other table (states missing or sampled now and then, outputs such as the cell voltage) the
    filter's or multiple shooting's (:mod:`.sparse`, :func:`discovery_route`), with
    ``declared_noise`` for channels too sparse to estimate it.
    ``name`` keys the random streams; ``source`` names the data in error messages;
    ``first_round``: the sparse route's first-round records, where separate jobs made them.
    """
    route = discovery_route(config, name, [train, held_out])
    log.info("%s: the %s route (%s)", source, route.name, route.why)
    settings = search_settings(config, name, route)
    floor_rng = seeds.numpy_generator(config["seed"], 0, f"discovery/{name}/floor")
    if route.name != "full_state":
        evaluation = gap_settings(config, name, int(held_out.groupby("trajectory").size().iloc[0]))
        result = run_sparse_discovery(
            train, held_out, start=start, settings=settings, evaluation=evaluation, declared_noise=declared_noise or {}, source=source, rng=floor_rng, first_round=first_round,
            restart_s=gap_restart_s(config, name),
        )  # fmt: skip
    else:
        result = run_full_state_discovery(
            train,
            held_out,
            start=start,
            settings=settings,
            evaluation_for=lambda steps: gap_settings(config, name, steps),
            source=source,
            floor_rng=floor_rng,
        )
    # every route's names, settled once its rounds have run (:func:`.core.naming.settled`)
    return replace(
        result,
        rounds=settled(result.rounds),
        constant_inputs=constant_inputs(train[list(INPUTS)].to_numpy()),
        records=route.records,
    )
