"""Closed forms fitted by multiple shooting on a pot line's record: the right hypothesis and its rivals.

Fits each (hypothesis, closed form) of a shipped case's list below to the first cells
of its ``plant`` record (the voltage every 10 s, the bath temperature hourly, AlF3 and
metal every 8 h, each tap weighed; 48 h) by multiple shooting over 1-hour segments
(:func:`costa.discover.sparse.shooting.shooting_fit`), from coefficients 0 and starts read
from the data alone, in one process and one thread, and prints the coefficients, the
cost (sum of squared residuals in noise stds: lower is likelier, the same count of
terms in every row of a case), each channel's mean square residual and the seconds.

    python benchmarks/shooting_fits.py [--cases conductivity_alf3 tapping_shortfall] [--cells 4] [--hours 48] [--iterations 8 30]
"""

from __future__ import annotations

import argparse
import os
import time

from costa.config import load_config
from costa.discover.cases.tables import case_tables
from costa.discover.core.hypotheses import candidate_hypotheses
from costa.discover.pipeline import starting_model
from costa.discover.sparse.pipeline import observations
from costa.discover.sparse.shooting.fit import shooting_fit
from costa.sensors import declared_noise

#: case -> (hypothesis, closed form) fitted: the right one first, then rivals with as many terms
FITS = {
    "conductivity_alf3": [
        ("part:bath_conductivity", ("own*(c3 - 0.11)", "own*(c3 - 0.11)^2")),
        ("input:u5", ("(c3 - 0.11)", "(c3 - 0.11)^2")),
        ("part:cell_voltage", ("own*(c3 - 0.11)", "own*(c3 - 0.11)^2")),
    ],
    "tapping_shortfall": [
        ("input:u4", ("1",)),
        ("property:current_efficiency", ("1",)),
        ("part:metal_production", ("own",)),
    ],
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(FITS), choices=list(FITS))
    parser.add_argument("--cells", type=int, default=4)
    parser.add_argument("--hours", type=float, default=48.0, help="each cell's record [h]")
    parser.add_argument("--iterations", type=int, nargs=2, default=(8, 30), help="of the states, then of everything")
    args = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")

    config = load_config("config/sensors.yaml")
    config["discovery"]["sensor_sets"]["plant"]["hours"] = args.hours
    declared = declared_noise(config["discovery"]["sensor_sets"], "plant")
    model = starting_model(config, "full")
    hypotheses = {h.key: h for h in candidate_hypotheses(model)}
    for case in args.cases:
        train, _ = case_tables(config, case, "plant")
        obs = observations(train, declared, case).subset(slice(0, args.cells))
        print(
            f"{case}, plant record: {args.cells} cells x {obs.y.shape[1] * obs.dt / 3600:g} h, channels {obs.channels}"
        )
        for key, names in FITS[case]:
            features = {f.name: f for f in hypotheses[key].features(rich=True)}
            started = time.perf_counter()
            fit = shooting_fit(
                model, hypotheses[key], [features[name] for name in names], obs, iterations=tuple(args.iterations)
            )
            seconds = time.perf_counter() - started
            form = " + ".join(f"{theta:+.4g} {name}" for theta, name in zip(fit.theta, names, strict=True))
            chi2 = ", ".join(f"{c} {v:.2f}" for c, v in fit.chi2.items())
            print(f"  {key:30s} {form:50s} cost {fit.cost:12.1f}  {chi2}  lost {fit.lost}  {seconds:6.1f} s")


if __name__ == "__main__":
    main()
