"""The plant search's shooting round, step by step: the screen, each fit and the verdict, with their seconds.

For each case, on ``--cells`` cells (from ``--first-cell`` on) of its ``plant`` record, as the
workflow's plant search does on the first 2 (:mod:`costa.discover.sparse.shooting.round`): the
channel tests of those cells, the uncorrected model's shooting fit and every hypothesis' closed
form screened at once (:func:`~costa.discover.sparse.shooting.round.screened_forms`), the
``--refine`` best by BIC gain and by the channels' predicted excess fitted one at a time
(:func:`~costa.discover.sparse.shooting.round.fit_by_shooting`), and the round decided
(:func:`~costa.discover.sparse.shooting.round.decide_by_shooting`).  Prints where the case's
accepted hypothesis ranks in the screen, each fit, the verdict, and the seconds a hypothesis costs
in the screen against one fit (the ratio: how many hypotheses the screen scores in the time of
one fit).  One process, one thread.  ``--true-model`` fits the case's true model instead (its
states alone): where that does not reach the noise, the fits measure the shooting fit's
failure, not the hypotheses.

    python benchmarks/form_screen.py [--cases tapping_shortfall alumina_feeder] [--cells 2] [--first-cell 0]
        [--hours 48] [--refine 3] [--iterations 8 30] [--hypotheses input:u4 ...] [--true-model]
"""

from __future__ import annotations

import argparse
import os
import time

from costa.config import load_config
from costa.discover.cases.tables import case_tables
from costa.discover.cases.unshipped import find_case
from costa.discover.core.hypotheses import candidate_hypotheses
from costa.discover.core.library import constant_inputs
from costa.discover.core.settings import DiscoverySettings
from costa.discover.pipeline import starting_model
from costa.discover.sparse.pipeline import observations
from costa.discover.sparse.rounds import channel_tests
from costa.discover.sparse.shooting.fit import shooting_fit
from costa.discover.sparse.shooting.round import (
    ShotScreen,
    by_excess,
    decide_by_shooting,
    fit_by_shooting,
    screened_forms,
    shooting_cells,
)
from costa.physics import model_from_config
from costa.sensors import declared_noise


def _rank(keys: list[str], accepted: tuple[str, ...]) -> str:
    return next((f"{i + 1}" for i, key in enumerate(keys) if key in accepted), "-")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", nargs="+", default=["tapping_shortfall", "alumina_feeder"])
    parser.add_argument("--cells", type=int, default=2)
    parser.add_argument("--first-cell", type=int, default=0, help="the record's cells used: from this one on")
    parser.add_argument("--hours", type=float, default=48.0, help="each cell's record [h]")
    parser.add_argument("--refine", type=int, default=3, help="forms fitted from each ranking of the screen")
    parser.add_argument("--iterations", type=int, nargs=2, default=(8, 30), help="of each shooting fit")
    parser.add_argument("--hypotheses", nargs="+", help="screen these alone (default: every hypothesis)")
    parser.add_argument(
        "--true-model",
        action="store_true",
        help="instead, fit the case's true model: the floor any correction can reach",
    )
    args = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")

    config = load_config("config/sensors.yaml")
    config["discovery"]["sensor_sets"]["plant"]["hours"] = args.hours
    declared = declared_noise(config["discovery"]["sensor_sets"], "plant")
    settings = DiscoverySettings(
        shooting_cells=args.cells, shooting_refine=args.refine, shooting_iterations=tuple(args.iterations)
    )
    for name in args.cases:
        case = find_case(name)
        model = starting_model(config, case.starting)
        train, _ = case_tables(config, name, "plant")
        cells = slice(args.first_cell, args.first_cell + args.cells)
        obs = observations(train, declared, name).subset(cells)
        few = shooting_cells(obs, args.cells)
        if args.true_model:
            started = time.perf_counter()
            true, _ = case.models(model_from_config(config["physics"])[0])
            fit = shooting_fit(true, None, [], few, iterations=tuple(args.iterations))
            chi2 = ", ".join(f"{c} {v:.2f}" for c, v in fit.chi2.items())
            print(f"{name}: the true model's own fit: cost {fit.cost:.0f}, {chi2}, "
                  f"{fit.iterations} iterations, {time.perf_counter() - started:.1f} s")  # fmt: skip
            continue
        obs = obs.with_start(model)  # the screen's tests and the decision's filters start there
        tests, _ = channel_tests(model, obs, settings, backward=False)
        hypotheses = [
            h for h in candidate_hypotheses(model, constant_inputs(obs.u)) if h.key in (args.hypotheses or [h.key])
        ]
        started = time.perf_counter()
        base, forms, candidates = screened_forms(model, hypotheses, few, settings)
        screened = time.perf_counter() - started
        print(
            f"{name} (cells {cells.start}-{cells.stop - 1} x {few.y.shape[1] * few.dt / 3600:g} h; "
            f"accepted {list(case.accepted)}): flagged {[t.channel for t in tests if t.flagged]}; "
            f"screen of {len(forms)} hypotheses {screened:.1f} s; uncorrected excess {base.excess:.2f}; "
            f"accepted ranks {_rank([f.hypothesis.key for f in forms], case.accepted)} by BIC gain, "
            f"{_rank([f.hypothesis.key for f in by_excess(forms)], case.accepted)} by excess"
        )
        screen = ShotScreen(tests=tests, base=base, forms=forms, candidates=candidates)
        fits, seconds = [], []
        for i, form in enumerate(candidates):
            started = time.perf_counter()
            fits += fit_by_shooting(model, screen, obs, settings, slice(i, i + 1))
            seconds.append(time.perf_counter() - started)
            fit = fits[-1].fit
            terms = " + ".join(f"{t:+.4g} {f.name}" for t, f in zip(fit.theta, form.features, strict=True))
            chi2 = ", ".join(f"{c} {v:.2f}" for c, v in fit.chi2.items())
            noise = "at noise" if fit.at_noise else "flagged"
            print(f"  {form.hypothesis.key:36s} {terms:60s} cost {fit.cost:10.0f} (cells {fit.cell_cost.round()})  "
                  f"{chi2} ({noise})  {seconds[-1]:5.1f} s")  # fmt: skip
        found = decide_by_shooting(model, screen, fits, obs, settings)
        keys = [c.hypothesis.key for c in found.ranking]
        print(f"  ranked: {keys}; accepted ranks {_rank(keys, case.accepted)}")
        print(f"  verdict: {found.verdict}")
        if seconds:
            one = sum(seconds) / len(seconds)
            print(f"  one fit {one:.1f} s, a hypothesis in the screen {screened / len(forms):.2f} s: "
                  f"{one * len(forms) / screened:.1f}x")  # fmt: skip


if __name__ == "__main__":
    main()
