"""One model type's rolling forecasts on the test set, reduced to tidy tables."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .forecast import rollout_networks, rollout_physics
from .metrics import EvaluationSettings, metrics_table, per_state_table, state_scale
from .models import load_models
from .physics import CellModel, model_from_config
from .variables import STATES

__all__ = ["DISCOVERED", "Evaluation", "PBM", "evaluate", "forecast_table"]

#: the name the ablated physics model is evaluated under
PBM = "pbm"
#: the name the discovery's corrected model is evaluated under (config/beyond.yaml)
DISCOVERED = "discovered"


@dataclass(frozen=True)
class Evaluation:
    """Metrics (coded and printed), per-state errors and the saved forecasts of one model type."""

    metrics: pd.DataFrame
    per_state: pd.DataFrame
    forecasts: pd.DataFrame


def forecast_table(model: str, x_hat: np.ndarray, trajectories: Sequence[int]) -> pd.DataFrame:
    """Full forecasts (E, T, K, 8) of some trajectories as a tidy float32 table (a blown-up
    state beyond float32's range is stored as +-inf)."""
    chosen = x_hat[:, list(trajectories)]
    instance, trajectory, step = np.indices(chosen.shape[:3])
    table = pd.DataFrame(
        {
            "model_type": model,
            "instance": instance.ravel().astype(np.int32),
            "trajectory": np.asarray(trajectories, dtype=np.int32)[trajectory.ravel()],
            "step": step.ravel().astype(np.int32),
        }
    )
    with np.errstate(over="ignore"):
        for i, name in enumerate(STATES):
            table[name] = chosen[..., i].ravel().astype(np.float32)
    return table


def evaluate(
    config: Mapping,
    model: str,
    x_test: np.ndarray,
    u_test: np.ndarray,
    x_train: np.ndarray,
    model_paths: Sequence[str | Path] = (),
    physics: CellModel | None = None,
) -> Evaluation:
    """Roll out ``model`` (a trained type, :data:`PBM`, or a physics model given as ``physics``,
    e.g. the discovery's corrected model) on every test trajectory and score it; physics
    models run as the PBM does (RK4 from the first true sample)."""
    evaluation = config["evaluation"]
    settings = EvaluationSettings.from_config(evaluation)
    settings.check(x_test.shape[1])
    dt = config["simulation"]["dt_s"]
    if model == PBM or physics is not None:
        physics = model_from_config(config["physics"])[1] if physics is None else physics
        x_hat = rollout_physics(physics, x_test, u_test, dt, evaluation["copied_samples"]["physics"])[None]
    else:
        if not model_paths:
            raise ValueError(f"{model}: no trained instances given")
        x_hat = rollout_networks(load_models(model_paths), x_test, u_test, dt, evaluation["copied_samples"]["networks"])
    scale = state_scale(x_train)
    saved = [t for t in evaluation["saved_trajectories"] if t < x_test.shape[0]]
    return Evaluation(
        metrics_table(model, x_hat, x_test, scale, settings),
        per_state_table(model, x_hat, x_test, scale, settings),
        forecast_table(model, x_hat, saved),
    )
