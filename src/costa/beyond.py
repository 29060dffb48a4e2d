"""Past the paper's forecasts (config/beyond.yaml): noisy training sets, the discovered model
on the paper's test set, and the noise study's table.

- Noise: Gaussian measurement noise of ``level`` percent of each state's std over
  the training set, from its own named stream per replicate and level; the test
  set stays clean.
- The discovered model: the discovery workflow (:func:`costa.discover.pipeline.run_discovery`)
  run on a training set with the ablated PBM as its start; its corrected model is
  rolled out like the PBM.  Discovery tests each equation against the data's
  measurement noise, so a noise-free simulated set gets ``floor_noise`` (a fraction
  of each state's std) added first; a run is deterministic, so the model is rebuilt
  by rerunning it rather than stored (a model holds code).
- The noise table: per noise level, model type and window, the spread over
  replicates and the two-level bootstrap intervals of :mod:`costa.replicates`.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from . import seeds
from .data import arrays, to_table
from .discover.cases.shipped import add_noise
from .discover.core.outcome import Outcome
from .discover.pipeline import run_discovery, starting_model
from .replicates import aggregate_table
from .summary import summary_table

__all__ = ["discover_on_training_set", "noise_table", "noisy_table"]


def noisy_table(table: pd.DataFrame, level_percent: float, seed: int, replicate: int) -> pd.DataFrame:
    """A trajectory table with noise of ``level_percent`` % of each state's std added to its states."""
    x, u = arrays(table)
    dt = float(np.diff(table["time_s"].to_numpy()[:2])[0])
    rng = seeds.numpy_generator(seed, replicate, f"beyond/noise/{level_percent:g}")
    return to_table(add_noise(x, level_percent / 100, rng), u, dt)


def discover_on_training_set(
    config: Mapping, train: pd.DataFrame, held_out: pd.DataFrame, name: str, floor_noise: float
) -> Outcome:
    """Discovery from the ablated PBM on ``train`` (plus ``floor_noise`` of each state's std,
    from stream ``beyond/<name>/floor_noise``); the gap is measured on ``held_out``."""
    if floor_noise:
        x, u = arrays(train)
        rng = seeds.numpy_generator(config["seed"], 0, f"beyond/{name}/floor_noise")
        dt = float(np.diff(train["time_s"].to_numpy()[:2])[0])
        train = to_table(add_noise(x, floor_noise, rng), u, dt)
    start = starting_model(config, "ablated")
    return run_discovery(config, train, held_out, start, f"beyond/{name}", "the training set")


def noise_table(metrics: pd.DataFrame, resamples: int, confidence: float, seed: int) -> pd.DataFrame:
    """One row per noise level, model type and window (coded metric) from per-rollout metrics with
    ``noise`` (percent) and ``replicate`` columns: blow-ups and median AN-RFMSE per replicate
    (mean, min, max) with bootstrap intervals over replicates and instances
    (:func:`costa.replicates.aggregate_table`)."""
    frames = []
    for level, part in metrics.groupby("noise", sort=True):
        summaries = pd.concat(
            [
                summary_table(rows, resamples, confidence, seed).assign(replicate=replicate)
                for replicate, rows in part.groupby("replicate", sort=True)
            ],
            ignore_index=True,
        )
        table = aggregate_table(summaries, part, resamples, confidence, seed)
        frames.append(table.drop(columns=["paper_blowups", "out_of", "paper_median"]).assign(noise=level))
    table = pd.concat(frames, ignore_index=True)
    return table[["noise", *[c for c in table.columns if c != "noise"]]]
