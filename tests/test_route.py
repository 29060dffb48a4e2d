"""The route a record takes, chosen once from what it samples: the workflow and the run agree."""

from __future__ import annotations

import copy

import numpy as np
import pandas as pd
import pytest

from costa.discover.core.noise import estimate_noise
from costa.discover.pipeline import discovery_route, search_settings
from costa.discover.route import SHOOTING_CELLS, Route, choose_route, record_route
from costa.variables import INPUTS

DT = 10.0


def _table(every_s: dict[str, float], hours: float = 48.0, cells: int = 3, missing: str | None = None) -> pd.DataFrame:
    """Cells of ``hours`` at 10 s steps, each channel sampled every ``every_s[channel]`` s from the start;
    ``missing``: a channel that lacks one sample of the last cell."""
    steps = int(hours * 3600 / DT)
    time = np.arange(steps) * DT
    frames = []
    for cell in range(cells):
        frame = pd.DataFrame({"trajectory": cell, "time_s": time} | {u: 1.0 for u in INPUTS})
        for channel, every in every_s.items():
            frame[channel] = np.where(time % every == 0, 1.0, np.nan)
        frames.append(frame)
    table = pd.concat(frames, ignore_index=True)
    if missing:
        table.loc[len(table) - 5, missing] = np.nan
    return table


def _declared(sensor_set: dict) -> dict[str, float]:
    """A sensor set's declared intervals as the workflow reads them (taps left out)."""
    return {c: float(s["every_s"]) for c, s in sensor_set["channels"].items() if s["every_s"] != "tap"}


HOURLY_AND_SHIFT = {"U_cell": 10.0, "x6": 3600.0, "c3": 28800.0, "x5": 28800.0}
DAILY = {"U_pot": 10.0, "x6": 86400.0, "c3": 86400.0, "x5": 86400.0}


def test_the_shipped_sensor_sets_take_their_documented_routes(default_config):
    """full: the full-state route; partial (the composition every step) and pot_line (daily hand
    samples): the filter; plant (bath temperature hourly, hand samples every 8 h): multiple shooting
    on 2 cells, without the set saying so; regimes as declared (a shipped case's record): as pot_line."""
    sets = default_config["discovery"]["sensor_sets"]
    routes = {name: choose_route(_declared(s), dt_s=DT) for name, s in sets.items()}
    assert {name: (r.name, r.shooting_cells, r.records) for name, r in routes.items()} == {
        "full": ("full_state", 0, "full"),
        "partial": ("filter", 0, "partial"),
        "plant": ("shooting", SHOOTING_CELLS, "plant"),
        "pot_line": ("filter", 0, "pot_line"),
        "regimes": ("filter", 0, "pot_line"),
    }
    # a pot line's record quotes the pot line's rates, whichever route a user chooses for it
    assert choose_route(DAILY, dt_s=DT, shooting_cells=2).records == "pot_line"
    assert choose_route(HOURLY_AND_SHIFT, dt_s=DT, shooting_cells=0).records == "plant"


@pytest.mark.parametrize("name", ["full", "partial", "plant", "pot_line"])
def test_a_record_sampled_as_its_set_declares_takes_the_route_the_workflow_plans(default_config, name):
    """The workflow plans a set's jobs from its declared intervals, the run reads the record's own:
    on a record sampled as declared they choose the same route."""
    sensor_set = default_config["discovery"]["sensor_sets"][name]
    declared = _declared(sensor_set)
    record = _table(declared, hours=sensor_set.get("hours", 48.0))
    assert record_route([record, record], DT) == choose_route(declared, dt_s=DT)


def test_your_hourly_and_shift_samples_get_multiple_shooting_without_asking(default_config):
    """A user's record with the bath temperature hourly and hand samples every shift takes the
    shooting route on 2 cells with no ``shooting_cells``; daily samples take the filter; a stated
    ``shooting_cells`` is obeyed (0: the filter) unless the composition is logged at every step."""
    config = copy.deepcopy(default_config)
    shift, daily = _table(HOURLY_AND_SHIFT), _table(DAILY, hours=120)
    config["discovery"]["user_data"] = {"name": "pot12"}
    route = discovery_route(config, "pot12", [shift, shift])
    assert (route.name, route.shooting_cells) == ("shooting", 2)
    assert search_settings(config, "pot12", route).shooting_cells == 2
    assert discovery_route(config, "pot12", [daily, daily]).name == "filter"
    config["discovery"]["user_data"] = {"name": "pot12", "shooting_cells": 3}
    assert discovery_route(config, "pot12", [daily, daily]).shooting_cells == 3
    logged = _table({"c2": DT, "c3": DT, "x6": DT})
    assert discovery_route(config, "pot12", [logged, logged]).name == "filter"
    config["discovery"]["user_data"] = {"name": "pot12", "shooting_cells": 0}
    assert discovery_route(config, "pot12", [shift, shift]).name == "filter"


def test_a_set_that_knows_its_noise_states_a_smaller_material_excess(default_config):
    """The partial set estimates each channel's noise from 200,000 second differences: a variance known
    far better than its 3 % materiality (a smooth drift plus white noise: the estimate is off by under
    1 %), which its records and no other set's use; your record states its own or takes the default."""
    rng = np.random.default_rng(1)
    drift = np.cumsum(rng.normal(size=(40, 5000, 1)) * 1e-3, axis=1)
    estimated = estimate_noise(drift + rng.normal(size=drift.shape) * 0.05)[0]
    material = default_config["discovery"]["sensor_sets"]["partial"]["min_excess"]
    assert abs((estimated / 0.05) ** 2 - 1) < material / 3
    route = Route(name="filter", why="", records="partial")
    assert search_settings(default_config, "drawn3/partial", route).min_excess == material
    assert (
        search_settings(default_config, "drawn3/plant", route).min_excess == default_config["discovery"]["min_excess"]
    )
    config = copy.deepcopy(default_config)
    config["discovery"]["user_data"] = {"name": "pot12", "min_excess": 0.05}
    assert search_settings(config, "pot12", route).min_excess == 0.05


def test_one_missing_state_sample_leaves_the_full_state_route():
    """Every state at every step of both tables, or not the full-state route: one held-out sample
    of the ledge missing sends the record to the filter (the weak form needs every step)."""
    every = {f"x{i}": DT for i in range(1, 9)}
    full = _table(every, hours=2)
    assert record_route([full, full], DT).name == "full_state"
    assert record_route([full, _table(every, hours=2, missing="x3")], DT).name == "filter"  # no hand samples


def test_hand_samples_once_a_cell_are_not_every_shift():
    """A record shorter than the hand samples' interval (one sample a cell) cannot be fitted by
    shooting on those samples: the filter."""
    assert record_route([_table(HOURLY_AND_SHIFT, hours=6)], DT).name == "filter"
