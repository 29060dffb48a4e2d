"""Candidate closed forms scored per second on a pot line's record: one batch against one at a time.

Scores a grid of coefficient values of one closed form (a heat flow missing from the
bath: a constant and a slope in the bath temperature) on the first cells and hours of a
shipped case's ``plant`` record (the voltage every 10 s, the bath temperature hourly,
AlF3 and metal every 8 h), in one process and one thread (as a Snakemake job):

  (a) every candidate x cell a row of one pass of the filter
      (:func:`costa.discover.sparse.batched.closed_form_likelihoods`);
  (b) the same candidates one at a time, one pass each (today's estimator, a filter per model);

checks that both give the same log-likelihoods to rounding, and prints candidates per
second and the ratio.

    python benchmarks/candidate_scores.py [--case top_heat_loss] [--cells 4] [--hours 12] [--candidates 64]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from costa.config import load_config
from costa.discover.cases.tables import case_tables
from costa.discover.core.hypotheses import candidate_hypotheses
from costa.discover.pipeline import starting_model
from costa.discover.sparse.batched import closed_form_likelihoods
from costa.discover.sparse.pipeline import observations
from costa.sensors import declared_noise


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--case", default="top_heat_loss")
    parser.add_argument("--cells", type=int, default=4)
    parser.add_argument("--hours", type=float, default=12.0)
    parser.add_argument("--candidates", type=int, default=64)
    args = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")

    config = load_config("config/sensors.yaml")
    train, _ = case_tables(config, args.case, "plant")
    obs = observations(train, declared_noise(config["discovery"]["sensor_sets"], "plant"), args.case)
    steps = round(args.hours * 3600 / obs.dt)
    obs = obs.subset(slice(0, args.cells))
    obs = type(obs)(obs.y[:, :steps], obs.u[:, :steps], obs.channels, obs.noise, obs.dt, obs.start)
    model = starting_model(config, "full")
    (h,) = [h for h in candidate_hypotheses(model) if h.key == "term:bath_energy"]
    features = [f for f in h.features(False) if f.name in ("1", "(x6 - 970)")]
    side = int(np.ceil(np.sqrt(args.candidates)))
    grid = np.array([(a, b) for a in np.linspace(-4e4, 0, side) for b in np.linspace(-600, 0, side)])[: args.candidates]

    started = time.perf_counter()
    batched = closed_form_likelihoods(model, h, features, grid, obs)
    batched_s = time.perf_counter() - started
    started = time.perf_counter()
    alone = np.concatenate([closed_form_likelihoods(model, h, features, row[None], obs) for row in grid])
    alone_s = time.perf_counter() - started
    np.testing.assert_allclose(batched, alone, rtol=1e-9)

    print(f"{args.case}, plant record: {args.cells} cells x {args.hours:g} h ({steps} steps), channels {obs.channels}")
    print(f"{len(grid)} candidates ({h.key}: {' + '.join(f.name for f in features)}), equal to rounding")
    print(f"(a) one batch       {batched_s:8.2f} s  {len(grid) / batched_s:8.2f} candidates/s")
    print(f"(b) one at a time   {alone_s:8.2f} s  {len(grid) / alone_s:8.2f} candidates/s")
    print(f"batched / one at a time: {alone_s / batched_s:.1f}x")


if __name__ == "__main__":
    main()
