"""Every hypothesis' closed forms screened at once by shooting, then the best fitted one at a time.

For each case: the uncorrected model's states are fitted by multiple shooting on the first
cells of its ``plant`` record (at the continuity stages ``--screen-stages``, by default the
first), every hypothesis' closed form is scored linearised at that fit
(:func:`costa.discover.sparse.form_screen.screen_forms`), and the ``--refine`` best by BIC gain
and the ``--refine`` best by the channels' predicted excess are fitted nonlinearly
(:func:`costa.discover.sparse.form_screen.grown_form`, each grown ``--grow`` times around its
own fit), then ranked (:func:`costa.discover.sparse.form_screen.ranked_fits`).  Prints where the
case's accepted hypothesis ranks at each stage, whether the first fit is told apart from its
rivals, and the seconds a hypothesis costs in the screen against one fit of it
(the ratio: how many hypotheses the screen scores in the time of one fit).  One process,
one thread.  ``--true-model`` fits the case's true model instead (its states alone): where
that does not reach the noise, the fits measure the shooting fit's failure, not the hypotheses.

    python benchmarks/form_screen.py [--cases tapping_shortfall alumina_feeder] [--cells 2] [--first-cell 0]
        [--hours 48] [--refine 3] [--iterations 8 30] [--fit-iterations 8 30] [--hypotheses input:u4 ...] [--grow 0]
        [--screen-stages 100] [--true-model]

The fits go through every continuity stage and are compared with the uncorrected model's fit
continued to the last.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from costa.config import load_config
from costa.discover.cases.tables import case_tables
from costa.discover.cases.unshipped import find_case
from costa.discover.core.hypotheses import candidate_hypotheses
from costa.discover.core.library import constant_inputs
from costa.discover.pipeline import starting_model
from costa.discover.sparse.form_screen import FittedForm, grown_form, ranked_fits, screen_forms
from costa.discover.sparse.pipeline import observations
from costa.discover.sparse.shooting import CONTINUITY_STAGES, shooting_fit
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
    parser.add_argument("--refine", type=int, default=3, help="forms fitted nonlinearly from each ranking")
    parser.add_argument("--iterations", type=int, nargs=2, default=(8, 30), help="of the uncorrected model's states")
    parser.add_argument("--fit-iterations", type=int, nargs=2, default=(8, 30), help="of each nonlinear fit")
    parser.add_argument("--hypotheses", nargs="+", help="screen these alone (default: every hypothesis)")
    parser.add_argument("--grow", type=int, default=0, help="rounds each fitted form may grow around its own fit")
    parser.add_argument(
        "--screen-stages",
        type=float,
        nargs="+",
        default=CONTINUITY_STAGES[:1],
        help="the continuity stages of the fit the screen is linearised at (the fits use every stage)",
    )
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
    for name in args.cases:
        case = find_case(name)
        model = starting_model(config, case.starting)
        train, _ = case_tables(config, name, "plant")
        obs = observations(train, declared, name).subset(slice(args.first_cell, args.first_cell + args.cells))
        if args.true_model:
            started = time.perf_counter()
            true, _ = case.models(model_from_config(config["physics"])[0])
            fit = shooting_fit(true, None, [], obs, iterations=tuple(args.fit_iterations))
            chi2 = ", ".join(f"{c} {v:.2f}" for c, v in fit.chi2.items())
            print(f"{name}: the true model's own fit: cost {fit.cost:.0f}, {chi2}, "
                  f"{fit.iterations} iterations, {time.perf_counter() - started:.1f} s")  # fmt: skip
            continue
        hypotheses = [
            h for h in candidate_hypotheses(model, constant_inputs(obs.u)) if h.key in (args.hypotheses or [h.key])
        ]
        started = time.perf_counter()
        base, forms = screen_forms(model, hypotheses, obs, iterations=tuple(args.iterations), stages=args.screen_stages)
        screened = time.perf_counter() - started
        if tuple(args.screen_stages[-1:]) != CONTINUITY_STAGES[-1:]:  # the fits are compared at the last stage
            later = CONTINUITY_STAGES[CONTINUITY_STAGES.index(args.screen_stages[-1]) + 1 :]
            base = shooting_fit(
                model, None, [], obs, iterations=tuple(args.iterations), starts=base.starts, stages=later
            )
        by_excess = sorted(forms, key=lambda f: (round(f.excess, 2), -f.bic_gain))
        print(
            f"{name} (cells {args.first_cell}-{args.first_cell + args.cells - 1} x {obs.y.shape[1] * obs.dt / 3600:g} h; "
            f"accepted {list(case.accepted)}): "
            f"screen of {len(forms)} hypotheses {screened:.1f} s; uncorrected excess {base.excess:.2f}; "
            f"accepted ranks {_rank([f.hypothesis.key for f in forms], case.accepted)} by BIC gain, "
            f"{_rank([f.hypothesis.key for f in by_excess], case.accepted)} by excess"
        )
        chosen = list({id(f): f for f in forms[: args.refine] + by_excess[: args.refine] if f.features}.values())
        penalty = np.log(int(np.isfinite(obs.y).sum()))
        fitted, seconds = [], []
        for form in chosen:
            started = time.perf_counter()
            features, fit = grown_form(
                model, form.hypothesis, form.features, obs, rounds=args.grow, iterations=tuple(args.fit_iterations)
            )
            seconds.append(time.perf_counter() - started)
            gain = base.cost - fit.cost - len(features) * penalty
            corrected = form.hypothesis.corrected(model, features, fit.theta)
            cells = base.cell_cost - fit.cell_cost
            fitted.append(FittedForm(form.hypothesis, tuple(features), fit, gain, cells, corrected))
            terms = " + ".join(f"{t:+.4g} {f.name}" for t, f in zip(fit.theta, features, strict=True))
            chi2 = ", ".join(f"{c} {v:.2f}" for c, v in fit.chi2.items())
            noise = "at noise" if fit.at_noise else "flagged"
            print(f"  {form.hypothesis.key:36s} {terms:60s} BIC gain {gain:10.0f} (cells {np.round(cells)})  "
                  f"{chi2} ({noise})  "
                  f"{seconds[-1]:5.1f} s")  # fmt: skip
        if fitted:
            hourly = obs.u[:, :: round(3600 / obs.dt)][:, : base.starts.shape[1]]
            ranking = ranked_fits(
                fitted, model, base.starts.reshape(-1, 8), hourly.reshape(-1, 5), penalty, base.excess
            )
            keys = [f.hypothesis.key for f in ranking.order]
            print(f"  ranked: {keys}; accepted ranks {_rank(keys, case.accepted)}")
            print(f"  verdict: {ranking.verdict}")
            print(f"  one fit {np.mean(seconds):.1f} s, a hypothesis in the screen {screened / len(forms):.2f} s: "
                  f"{np.mean(seconds) * len(forms) / screened:.1f}x")  # fmt: skip


if __name__ == "__main__":
    main()
