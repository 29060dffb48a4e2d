"""Blow-ups and medians of one trained CoSTA type's instances under each bound (docs/beyond.md).

Rolls the saved instances of a type (default: the sparse CoSTA of a finished run) out on
the test set again, plain and under each ``source_bound`` / ``rate_bound`` variant: the
same weights, so the rows differ only by the bound.  Prints blow-ups per coded window and
the median AN-RFMSE of the rollouts that did not blow up, per replicate folder given.

    python benchmarks/bound_variants.py [--results results] [--reps "" replicates/r1/ ...]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import pandas as pd
import torch

from costa.config import load_config
from costa.data import arrays, load_trajectories
from costa.forecast import rollout_networks
from costa.metrics import EvaluationSettings, metrics_table, state_scale
from costa.models import NetworkModel, load_models
from costa.physics import model_from_config
from costa.train import training_data


def _source(margin: float, inputs: bool = False) -> dict:
    return {"margin": margin, "inputs": inputs}


#: the rows of docs/beyond.md's table: name -> the bound options of the model type
VARIANTS = {
    "none": {},
    "source, margin 0": {"source_bound": _source(0.0)},
    "source, margin 0.1": {"source_bound": _source(0.1)},
    "source, margin 0, inputs clamped": {"source_bound": _source(0.0, inputs=True)},
    "inputs clamped only": {"source_bound": _source(1e9, inputs=True)},
    "rate, margin 0": {"rate_bound": {"margin": 0.0}},
    **{
        f"source margin {m:g} and rate margin 0": {"source_bound": _source(m), "rate_bound": {"margin": 0.0}}
        for m in (0.25, 0.5, 1.0)
    },
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", default="results")
    parser.add_argument("--reps", nargs="*", default=[""], help='replicate prefixes, e.g. "" replicates/r1/')
    parser.add_argument("--model-type", default="costa_sparse")
    parser.add_argument("--config", nargs="*", default=[])
    parser.add_argument("--variants", nargs="*", default=list(VARIANTS), choices=list(VARIANTS))
    args = parser.parse_args()
    torch.set_num_threads(1)
    config = load_config(*args.config)
    settings = EvaluationSettings.from_config(config["evaluation"])
    dt, copied = config["simulation"]["dt_s"], config["evaluation"]["copied_samples"]["networks"]
    pbm = model_from_config(config["physics"])[1]
    rows = []
    for rep in args.reps:
        folder = Path(args.results) / rep
        x, u = arrays(load_trajectories(folder / "data/train.parquet"))
        x_test, u_test = arrays(load_trajectories(folder / "data/test.parquet"))
        trained = load_models(sorted((folder / "models" / args.model_type).glob("instance*.pt")))
        # the ranges, recomputed so that instances saved before they were stored work too
        normalisation = training_data(x, u, dt, trained.model_type.target, pbm, trained.model_type.savgol).normalisation
        for variant in args.variants:
            options = VARIANTS[variant]
            model_type = dataclasses.replace(
                trained.model_type, **{"source_bound": None, "rate_bound": None, **options}
            )
            model = NetworkModel(model_type, trained.ensemble, normalisation, pbm, {})
            forecasts = rollout_networks(model, x_test, u_test, dt, copied)
            coded = metrics_table(variant, forecasts, x_test, state_scale(x), settings).query("definition == 'coded'")
            for window, part in coded.groupby("window", sort=False):
                kept = part.loc[~part.blown_up, "error"]
                rows.append((rep or "r0", variant, window, int(part.blown_up.sum()), kept.median()))
            print(pd.DataFrame(rows[-len(settings.windows) :]).to_string(header=False, index=False), flush=True)
    table = pd.DataFrame(rows, columns=["replicate", "bound", "window", "blowups", "median"])
    print(table.pivot_table(index=["bound", "replicate"], columns="window", values=["blowups", "median"], sort=False))


if __name__ == "__main__":
    main()
