"""The two peers of the discovery workflow, on the same training data and starting model.

- **PySINDy** on the residual of the starting model: targets xdot - f_start(x, u) from
  PySINDy's smoothed finite differences (Savitzky-Golay, then central differences),
  STLSQ, and its bagging ensemble for inclusion frequencies.  The starting model's
  rates and the library pass through the same filter as the derivative
  (:func:`filtered_regression`): evaluated sample by sample, as in plain SINDYc, they
  carry the one-step feed impulses that the smoothed derivative spreads, and the
  regression then fits the impulses' mismatch rather than the missing physics.
- **The UDE recipe** (Rackauckas et al. 2020): a CoSTA network learns the missing rate
  inside the starting model (this project's training, the CoSTA reference's size and
  seeds, on the residual of one solver step: :func:`solver_step_targets`), then
  PySINDy's STLSQ (and ensemble) turns the network's output at the training states
  into a formula.

Each peer's hyper-parameters (PySINDy: the threshold and the smoothing window; UDE:
the threshold) are chosen on the training data only: the last quarter of the training
trajectories is held back, every grid point is fitted on the rest, its corrected model
is rolled out on the held-back trajectories, and the sparsest fit whose long-window
error (median coded AN-RFMSE) is within ``tolerance`` of the best is chosen.  The
chosen setting is then refitted on all training trajectories with the ensemble.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd
import pysindy as ps
import torch
from scipy.signal import savgol_filter

from ..forecast import rollout_physics
from ..integrate import rk4_step
from ..metrics import EvaluationSettings, per_step_error, window_metrics
from ..physics import CellModel
from ..train import TrainingData, training_data
from .sparse import SparseFit, corrected_per_row, design, fit_sparse

__all__ = ["PeerResult", "PeerSettings", "pysindy_peer", "ude_peer", "network_correction"]


@dataclass(frozen=True)
class PeerSettings:
    """The grids and the fixed settings of both peers (``peers.*`` in the config)."""

    thresholds: tuple[float, ...] = (0.03, 0.1, 0.3)
    windows: tuple[int, ...] = (21, 81)  # Savitzky-Golay window lengths [samples]
    ensemble: int = 20  # bagged fits of the final regression (PySINDy's default)
    tolerance: float = 0.15  # sparsest fit within this share of the best validation error
    stride: int = 10  # every stride-th sample enters the regression
    seed: int = 0

    @classmethod
    def from_config(cls, peers: Mapping, seed: int) -> PeerSettings:
        return cls(tuple(peers["thresholds"]), tuple(peers["smoothing_windows"]), peers["ensemble"],
                   peers["tolerance"], peers["stride"], seed)  # fmt: skip


@dataclass
class PeerResult:
    """A peer's chosen fit, its corrected model, the grid it was chosen from, and its run time [s]."""

    method: str
    fit: SparseFit
    corrected: CellModel
    grid: pd.DataFrame
    seconds: float


def _split(n: int) -> tuple[slice, slice]:
    """Fit on the first three quarters of the training trajectories, validate on the rest."""
    held = max(1, n // 4)
    return slice(0, n - held), slice(n - held, n)


def validation_errors(
    model: CellModel,
    x: np.ndarray,
    u: np.ndarray,
    dt: float,
    scale: np.ndarray,
    evaluation: EvaluationSettings,
    blocks: int = 1,
) -> np.ndarray:
    """Median over rollouts of the coded AN-RFMSE in the longest window, per block: ``model``
    rolls out ``blocks`` copies of the trajectories x (T, K, 8) at once (:func:`corrected_per_row`)."""
    x, u = np.tile(x, (blocks, 1, 1)), np.tile(u, (blocks, 1, 1))
    error = per_step_error(rollout_physics(model, x, u, dt), x, scale, "absolute", evaluation.nonfinite_error)
    longest = max(evaluation.windows, key=lambda w: evaluation.windows[w][1])
    value, _ = window_metrics(error, {longest: evaluation.windows[longest]}, evaluation.blowup_threshold)[longest]
    return np.median(np.reshape(value, (blocks, -1)), axis=1)


def _choose(
    start: CellModel,
    problems: Mapping[tuple, Callable[[slice], tuple[np.ndarray, np.ndarray]]],
    x: np.ndarray,
    u: np.ndarray,
    dt: float,
    scale: np.ndarray,
    evaluation: EvaluationSettings,
    settings: PeerSettings,
    method: str,
) -> PeerResult:
    """Grid search on held-back training trajectories, then the chosen setting refitted on all.

    ``problems`` maps a setting (without the threshold) to a function of the trajectories
    to use that returns the library matrix (N, P) and the flow targets (N, 8).  Every grid
    point's corrected model is rolled out on the held-back trajectories in one batch.
    """
    started = time.perf_counter()
    fit_part, validate = _split(x.shape[0])
    rows, fits = [], []
    for key, problem in problems.items():
        theta, target = problem(fit_part)
        for threshold in settings.thresholds:
            fits.append(fit_sparse(theta, target, threshold, 1, settings.seed))
            rows.append({**dict(key), "threshold": threshold, "terms": fits[-1].n_terms})
    held = x[validate].shape[0]
    grid_model = corrected_per_row(start, fits, held, method)
    errors = validation_errors(grid_model, x[validate], u[validate], dt, scale, evaluation, len(fits))
    grid = pd.DataFrame(rows).assign(validation_error=errors)
    best = grid["validation_error"].min()
    good = grid[grid["validation_error"] <= best * (1 + settings.tolerance)]
    chosen = good.sort_values(["terms", "validation_error"], kind="stable").index[0]
    grid["chosen"] = grid.index == chosen
    setting = grid.loc[chosen]
    key = next(k for k in problems if all(setting[name] == value for name, value in k))
    theta, target = problems[key](slice(None))
    fit = fit_sparse(theta, target, float(setting["threshold"]), settings.ensemble, settings.seed)
    return PeerResult(method, fit, fit.corrected(start, method), grid, time.perf_counter() - started)


def _regression_rows(designs: np.ndarray, targets: np.ndarray, part: slice, edge: int, stride: int):
    """Trajectories ``part`` of designs (n, K, 8, P) and targets (n, K, 8): every ``stride``-th
    sample away from ``edge`` samples at either end, flattened to (N, 8, P) and (N, 8)."""
    steps = slice(edge, designs.shape[1] - edge, stride)
    return designs[part, steps].reshape(-1, *designs.shape[2:]), targets[part, steps].reshape(-1, 8)


def filtered_regression(
    start: CellModel, x: np.ndarray, u: np.ndarray, dt: float, window: int, stride: int
) -> tuple[np.ndarray, np.ndarray]:
    """Both sides of xdot = f_start(x, u) + J(x, u) Theta(x, u) xi through one Savitzky-Golay filter S.

    The left side is PySINDy's SmoothedFiniteDifference of the measured states: the central
    difference of S(x), which is S of the central difference.  The right side is S of the
    rates that central difference sees (the mean of the held-input rates of the two steps
    it spans), so that a feed impulse, which the smoothed derivative spreads over the
    window, is spread alike on both sides.  J is each balance's rate per flow.  Only every
    ``stride``-th sample is kept (the filtered rows are strongly correlated).
    Returns designs (n, K', 8, P) and targets (n, K', 8).
    """
    rates = np.empty_like(x)
    for i, trajectory in enumerate(x):
        rates[i] = ps.SmoothedFiniteDifference(smoother_kws={"window_length": window})(trajectory, t=dt)

    def filtered(values: np.ndarray) -> np.ndarray:
        mid = values.copy()
        mid[:, 1:] = 0.5 * (values[:, 1:] + values[:, :-1])
        return savgol_filter(mid, window, 3, axis=1)[:, ::stride]

    with np.errstate(all="ignore"):
        per_flow, rate = start.state_rate_per_flow(x, u), start.rhs(x, u)
    theta = design(start, x, u)
    designs = np.stack([filtered(per_flow[..., i, None] * theta) for i in range(8)], axis=2)
    return designs, rates[:, ::stride] - filtered(rate)


def pysindy_peer(
    start: CellModel,
    x: np.ndarray,
    u: np.ndarray,
    dt: float,
    scale: np.ndarray,
    evaluation: EvaluationSettings,
    settings: PeerSettings,
) -> PeerResult:
    """PySINDy on the starting model's residual, threshold and smoothing chosen on the training data."""

    def problem(window: int):
        designs, targets = filtered_regression(start, x, u, dt, window, settings.stride)
        edge = -(-window // (2 * settings.stride))  # the filter's edge samples, in kept rows
        return lambda part: _regression_rows(designs, targets, part, edge, 1)

    problems = {(("window", w),): problem(w) for w in settings.windows if w < x.shape[1]}
    return _choose(start, problems, x, u, dt, scale, evaluation, settings, "pysindy")


def solver_step_targets(data: TrainingData, start: CellModel, x: np.ndarray, u: np.ndarray, dt: float) -> TrainingData:
    """``data`` with the UDE's targets: the rate each measured step lacks after one RK4 step of
    the starting model, (x_{k+1} - Phi(x_k, u_k)) / dt, standardised like CoSTA's.

    The UDE recipe fits the network through the solver; against one solver step the network
    learns the missing rate, whereas forward differences minus f (CoSTA as published) also
    teach it the gap between a forward-Euler and an RK4 step, which an RK4 rollout of the
    sparse formula would then count twice."""
    with np.errstate(all="ignore"):
        step = rk4_step(start.rhs, x[:, :-1], u[:, :-1], dt)
    missing = ((x[:, 1:] - step) / dt).reshape(-1, 8) / data.normalisation.rate_std
    return TrainingData(data.inputs, torch.from_numpy(missing.astype(np.float32)), data.normalisation)


@torch.inference_mode()
def network_correction(network, x: np.ndarray, u: np.ndarray, chunk: int = 65536) -> np.ndarray:
    """The mean over instances of a CoSTA network's correction of the state rates (..., 8)."""
    flat_x, flat_u = x.reshape(-1, 8), u.reshape(-1, 5)
    out = np.empty_like(flat_x)
    for begin in range(0, flat_x.shape[0], chunk):
        xs = torch.from_numpy(np.ascontiguousarray(flat_x[begin : begin + chunk]))
        us = torch.from_numpy(np.ascontiguousarray(flat_u[begin : begin + chunk]))
        members = network.rhs(xs.expand(network.n_members, *xs.shape), us)
        with np.errstate(all="ignore"):
            out[begin : begin + chunk] = members.mean(0).numpy() - network.pbm.rhs(xs.numpy(), us.numpy())
    return out.reshape(x.shape)


def ude_peer(
    train_network: Callable[[TrainingData], object],
    start: CellModel,
    x: np.ndarray,
    u: np.ndarray,
    dt: float,
    scale: np.ndarray,
    evaluation: EvaluationSettings,
    settings: PeerSettings,
) -> PeerResult:
    """A CoSTA network with the starting model as physics (``train_network(data)``) trained on
    :func:`solver_step_targets`, then PySINDy's sparse regression of its correction at the training
    states; the threshold chosen on the training data."""
    started = time.perf_counter()
    network = train_network(solver_step_targets(training_data(x, u, dt, "costa", start), start, x, u, dt))
    trained = time.perf_counter() - started
    xs, us = x[:, :: settings.stride], u[:, :: settings.stride]
    with np.errstate(all="ignore"):
        per_flow = start.state_rate_per_flow(xs, us)
    designs = per_flow[..., None] * design(start, xs, us)[..., None, :]
    targets = network_correction(network, xs, us)
    problems = {(): lambda part: _regression_rows(designs, targets, part, 0, 1)}
    result = _choose(start, problems, x, u, dt, scale, evaluation, settings, "ude")
    result.seconds += trained
    return result
