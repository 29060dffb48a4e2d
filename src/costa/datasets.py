"""Simulated training and test sets, built from the validated config."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from .data import to_table
from .physics import model_from_config
from .simulate import SimulationSettings, simulate_set

__all__ = ["SPLITS", "simulate_split"]

#: split name -> config key of its size
SPLITS = {"train": "train_trajectories", "test": "test_trajectories"}


def simulate_split(config: Mapping, split: str, replicate: int) -> tuple[pd.DataFrame, dict]:
    """The tidy table of one split and its provenance (seed stream, attempts, model)."""
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}; known: {sorted(SPLITS)}")
    true, _ = model_from_config(config["physics"])
    settings = SimulationSettings.from_config(config["simulation"])
    stream = f"data/{split}"
    trajectories, attempts = simulate_set(
        true, settings, config["simulation"][SPLITS[split]], config["seed"], replicate, stream
    )
    q = true.quantities(trajectories.x, trajectories.u)
    derived = {"g1": q["liquidus_temperature"], "U_cell": q["cell_voltage"]}
    table = to_table(trajectories.x, trajectories.u, settings.dt, derived)
    provenance = {
        "seed": config["seed"],
        "replicate": replicate,
        "stream": stream,
        "model": true.name,
        "simulation_attempts": np.asarray(attempts).tolist(),
    }
    return table, provenance
