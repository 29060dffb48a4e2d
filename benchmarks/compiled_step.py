"""The compiled cell model against its numpy array code, in one process, and one plant case's stages.

1. The RK4 step with the channels read at every step (what a segment of multiple shooting and a
   rollout do), over 360 steps of 10 s from states and inputs of simulated cells: row-steps a
   second of numpy's array code and of the compiled march (:class:`costa.compiled.CompiledModel`),
   at the batch sizes the fits use (96 rows: a plant case's 2 cells x 48 hourly segments, each
   trial of Levenberg-Marquardt; 1152: the same with the 1 + 8 + 3 finite-difference rows a
   Jacobian took), and their ratio.
2. The sensitivities of those 96 segments to their 8 starts and 3 coefficients: by finite
   differences (1 + 8 + 3 marches, numpy and compiled) and by the compiled tangents; segment
   Jacobians a second and the ratio to numpy's.
3. With ``--case``, the stages of one ``plant`` case (``wall_conductivity`` by default) in this
   process, one thread: seconds of the screen, the candidates' fits and the gather, beside those
   measured on the last numpy tree (fb5c979, 2026-11-28, idle 2-core machine).
4. With ``--flags``, the compiler's options (:data:`costa.compiled.kernel.CFLAGS`) against ``-O2`` (the
   options until 2026-11-29): the filter screen's kernels of one ``partial`` case (``paper_liquidus``),
   each kind of hypothesis a model, compiled into an empty cache and run on 2 trajectories, seconds
   of each and whether the log-likelihoods are the same to the bit.

    python benchmarks/compiled_step.py [--case [NAME]] [--flags]
"""

from __future__ import annotations

import argparse
import os
import time
from dataclasses import replace

import numpy as np

from costa.compiled import CompiledModel, Parameters
from costa.config import load_config
from costa.discover.core.hypotheses import candidate_hypotheses
from costa.discover.sparse.observed import PRIOR_STD
from costa.discover.sparse.shooting.screen import screen_terms
from costa.integrate import rk4_step
from costa.observe import observe
from costa.physics import true_model
from costa.simulate import SimulationSettings, simulate_set

CHANNELS = ("U_cell", "x6", "c3", "x5")
STEPS = 360
#: seconds of each stage of wall_conductivity under plant on fb5c979 (numpy), measured through the
#: workflow on an idle 2-core machine (docs/results.md): screen, the fit jobs' CPU seconds added up, gather
NUMPY_STAGES = {"screen": 150.0, "fits (CPU s, all candidates)": 881.0 - 150.0 - 68.0 - 14.0, "gather": 68.0}


def _rows(count: int) -> tuple[np.ndarray, np.ndarray]:
    """Starts (count, 8) and inputs (count, STEPS, 5) of hourly segments of simulated cells (the paper's excitation)."""
    settings = replace(SimulationSettings.from_config(load_config()["simulation"]), steps=STEPS * 12)
    cells = simulate_set(true_model(), settings, 4, 0, 0, "benchmark", compiled=True)[0]
    starts = cells.x[:, ::STEPS].reshape(-1, 8)
    inputs = cells.u.reshape(-1, STEPS, 5)
    picked = np.arange(count) % len(starts)
    return starts[picked], inputs[picked]


def _rate(seconds: float, rows: int) -> float:
    return rows * STEPS / seconds


def _timed(function, repeats: int = 3) -> float:
    function()
    started = time.perf_counter()
    for _ in range(repeats):
        function()
    return (time.perf_counter() - started) / repeats


def step_rates() -> None:
    model = true_model()
    kernel = CompiledModel(model, 10.0, CHANNELS, derivatives=False)
    print("1. the step with its channels, row-steps a second (360 steps of 10 s)")
    print(f"   {'rows':>6} {'numpy':>12} {'compiled':>12} {'ratio':>7}")
    for rows in (96, 1152, 10000):
        x, u = _rows(rows)

        def numpy_march(x=x, u=u):
            with np.errstate(all="ignore"):
                for k in range(STEPS):
                    observe(model, x, u[:, k], CHANNELS)
                    x = rk4_step(model.rhs, x, u[:, k], 10.0)

        slow = _timed(numpy_march, 1)
        fast = _timed(lambda x=x, u=u: kernel.march(x, u))
        print(
            f"   {rows:>6} {_rate(slow, rows) / 1e6:>10.2f} M {_rate(fast, rows) / 1e6:>10.2f} M {slow / fast:>6.1f}x"
        )


def sensitivity_rates() -> None:
    model = true_model()
    hypothesis = next(h for h in candidate_hypotheses(model) if h.key == "part:bath_conductivity")
    features = screen_terms(hypothesis)[:3]
    theta = Parameters(len(features))
    corrected = hypothesis.parametrised(model, features, theta)
    kernel = CompiledModel(corrected, 10.0, CHANNELS, [theta])
    segments, terms = 96, len(features)
    x, u = _rows(segments)
    values = np.zeros((segments, terms))
    directions = 1 + 8 + terms
    xs = np.repeat(x[:, None], directions, 1)
    xs[:, 1:9] += np.diag(1e-4 * PRIOR_STD)
    ps = np.repeat(values[:, None], directions, 1)
    ps[:, 9:] += np.diag(np.full(terms, 1e-4))
    xs, ps, us = xs.reshape(-1, 8), ps.reshape(-1, terms), np.repeat(u, directions, 0)

    def numpy_differences():
        theta.value = ps
        with np.errstate(all="ignore"):
            state = xs
            for k in range(STEPS):
                observe(corrected, state, us[:, k], CHANNELS)
                state = rk4_step(corrected.rhs, state, us[:, k], 10.0)

    dx, dp = np.zeros((segments, 8, 8 + terms)), np.zeros((segments, terms, 8 + terms))
    dx[:, np.arange(8), np.arange(8)] = PRIOR_STD
    dp[:, np.arange(terms), 8 + np.arange(terms)] = 1.0
    slow = _timed(numpy_differences, 1)
    compiled_differences = _timed(lambda: kernel.march(xs, us, ps))
    tangents = _timed(lambda: kernel.march_tangents(x, u, values, dx, dp))
    print(f"2. sensitivities of {segments} hourly segments to 8 starts and {terms} coefficients, Jacobians a second")
    for name, seconds in (
        ("numpy, 1 + 8 + 3 differences", slow),
        ("compiled, 1 + 8 + 3 differences", compiled_differences),
        ("compiled tangents", tangents),
    ):
        print(f"   {name:<34} {segments / seconds:>10.0f} {slow / seconds:>6.1f}x")


def case_stages(case: str) -> None:
    from costa.discover.cases.tables import case_tables
    from costa.discover.cases.unshipped import find_case
    from costa.discover.pipeline import discovery_route, run_discovery, search_settings, starting_model
    from costa.discover.sparse.pipeline import fit_first_round, screen_first_round
    from costa.sensors import declared_noise

    config = load_config("config/config.yaml", "config/sensors.yaml")
    name, folder = f"{case}/plant", "benchmarks/results"
    os.makedirs(folder, exist_ok=True)
    train, held = case_tables(config, case, "plant")
    start = starting_model(config, find_case(case).starting)
    noise = declared_noise(config["discovery"]["sensor_sets"], "plant")
    settings = search_settings(config, name, discovery_route(config, name, [train, held]))
    screen, fits = f"{folder}/{case}_screen.pkl", f"{folder}/{case}_fits.pkl"
    seconds = {}
    started = time.perf_counter()
    screen_first_round(train, start, settings, noise, "train", screen)
    seconds["screen"] = time.perf_counter() - started
    started = time.perf_counter()
    fit_first_round(train, start, settings, noise, "train", screen, 0, 1, fits)
    seconds["fits (CPU s, all candidates)"] = time.perf_counter() - started
    started = time.perf_counter()
    result = run_discovery(config, train, held, start, name, "train", noise, (screen, [fits]))
    seconds["gather"] = time.perf_counter() - started
    print(f"3. {case} under plant, one process, one thread: {result.rounds[0].verdict[:100]}...")
    print(f"   {'stage':<30} {'compiled s':>11} {'numpy s':>9} {'ratio':>7}")
    for stage, value in seconds.items():
        print(f"   {stage:<30} {value:>11.1f} {NUMPY_STAGES[stage]:>9.1f} {NUMPY_STAGES[stage] / value:>6.1f}x")


def compiler_flags() -> None:
    import tempfile

    from costa.compiled import kernel
    from costa.discover.cases.tables import case_tables
    from costa.discover.pipeline import discovery_route, search_settings
    from costa.discover.sparse.filter.likelihood import _filter
    from costa.discover.sparse.pipeline import checked_observations
    from costa.sensors import declared_noise

    config = load_config("config/config.yaml", "config/sensors.yaml")
    name = "paper_liquidus/partial"
    train, held = case_tables(config, "paper_liquidus", "partial")
    settings = search_settings(config, name, discovery_route(config, name, [train, held]))
    noise = declared_noise(config["discovery"]["sensor_sets"], "partial")
    model = true_model()
    obs = checked_observations(train, noise, "train", settings).with_start(model).subset(slice(0, 2))
    hypotheses = candidate_hypotheses(model)
    current, cache_before, seconds, likelihoods = kernel.CFLAGS, os.environ.get("COSTA_KERNEL_CACHE"), {}, {}
    for flags in (current, ("-O2", *current[2:])):
        kernel.CFLAGS = flags
        with tempfile.TemporaryDirectory() as cache:
            os.environ["COSTA_KERNEL_CACHE"] = cache
            started = time.perf_counter()
            _filter(model, hypotheses, np.ones(len(hypotheses)), obs, settings.window, settings.walks, backward=False)
            first = time.perf_counter() - started
            started = time.perf_counter()
            _, result = _filter(
                model, hypotheses, np.ones(len(hypotheses)), obs, settings.window, settings.walks, backward=False
            )
            again = time.perf_counter() - started
        options = " ".join(flags[: len(flags) - len(current) + 2])  # what differs from the shared options
        seconds[options], likelihoods[flags] = (first - again, again), result.log_likelihood
    kernel.CFLAGS = current
    if cache_before is None:
        os.environ.pop("COSTA_KERNEL_CACHE")
    else:
        os.environ["COSTA_KERNEL_CACHE"] = cache_before
    same = np.array_equal(*likelihoods.values(), equal_nan=True)
    print(f"4. the filter screen's {len(hypotheses)} hypotheses on 2 partial trajectories, by compiler options")
    print(f"   {'options':<22} {'compile s':>10} {'run s':>7}")
    for options, (compiling, running) in seconds.items():
        print(f"   {options:<22} {compiling:>10.1f} {running:>7.1f}")
    (c_now, r_now), (c_before, r_before) = seconds.values()
    print(f"   ratios -O2 / now: compile {c_before / c_now:.2f}x, run {r_before / r_now:.2f}x; the same bits: {same}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--case", nargs="?", const="wall_conductivity", help="also time one plant case's stages")
    parser.add_argument("--flags", action="store_true", help="also compare the compiler's options with -O2")
    args = parser.parse_args()
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    step_rates()
    sensitivity_rates()
    if args.case:
        case_stages(args.case)
    if args.flags:
        compiler_flags()


if __name__ == "__main__":
    main()
