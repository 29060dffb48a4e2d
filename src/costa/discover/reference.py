"""CoSTA as a reference: a network correction of the starting model, trained on the same data."""

from __future__ import annotations

from collections.abc import Mapping

import pandas as pd

from .. import seeds
from ..data import arrays, incomplete_states, time_step
from ..forecast import rollout_networks
from ..metrics import state_scale
from ..models import NetworkModel
from ..physics import CellModel
from ..train import ModelType, TrainingData, TrainingSettings, train_ensemble, training_data
from .full_state.gap import gap_tables
from .pipeline import gap_settings

__all__ = ["costa_reference", "train_costa"]


def train_costa(config: Mapping, data: TrainingData, start: CellModel, name: str) -> NetworkModel:
    """A small CoSTA ensemble (``discovery.costa_reference``'s size) with ``start`` as its physics,
    trained on ``data`` (:func:`costa.train.training_data`: forward-difference targets, as published)."""
    reference = config["discovery"]["costa_reference"]
    training = {
        **config["training"],
        "instances": reference["instances"],
        "epochs": reference["epochs"],
        "compile": False,
    }
    settings = TrainingSettings.from_config(training)
    model_type = ModelType("costa_reference", "costa", 0.0)
    init = [
        seeds.torch_generator(config["seed"], 0, f"discovery/{name}/costa/init", i) for i in range(settings.instances)
    ]
    shuffle = seeds.torch_generator(config["seed"], 0, f"discovery/{name}/costa/shuffle")
    ensemble, _ = train_ensemble(data, model_type, settings, init, shuffle)
    return NetworkModel(model_type, ensemble, data.normalisation, start, {})


def costa_reference(
    config: Mapping, train: pd.DataFrame, held_out: pd.DataFrame, start: CellModel, name: str
) -> pd.DataFrame:
    """Train a small CoSTA ensemble on ``train`` with ``start`` as its physics; its gap on ``held_out``.

    CoSTA learns from forward differences of every state: on partial measurements there is no
    reference, and the table is empty (the findings' gap stands alone).
    """
    if incomplete_states(train) or incomplete_states(held_out):
        return pd.DataFrame(columns=["model", "window", "error", "mean", "blowups", "rollouts"])
    x, u = arrays(train)
    xh, uh = arrays(held_out)
    dt = time_step(train)
    network = train_costa(config, training_data(x, u, dt, "costa", start), start, name)
    forecasts = rollout_networks(network, xh, uh, dt, config["evaluation"]["copied_samples"]["networks"])
    evaluation = gap_settings(config, name, xh.shape[1])
    gap, _ = gap_tables({"CoSTA reference": forecasts}, xh, u=uh, dt=dt, scale=state_scale(x), settings=evaluation)
    return gap
