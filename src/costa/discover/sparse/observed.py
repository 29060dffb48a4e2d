"""The cell model seen through its sensors: a state-space model for the estimator, and its prior.

The states x1..x8 advance by one RK4 step of the model per sample (the inputs held,
as the data arise); the measured channels (:mod:`costa.sensors`) are read from the
states, and the cell voltage from the model's own parts, so a model whose voltage
is wrong shows it in the ``U_cell`` channel.  Both are compiled, with an extended
Kalman filter and smoother around them (:class:`...compiled.CompiledModel`).  Unmeasured states start from a wide
prior around a nominal operating point; measured ones from their first sample.

Where the bath composition is not sampled at the first step (a pot line's voltage and
hand samples hours apart), one voltage sample cannot place the alumina, AlF3 and bath
masses: the voltage is not monotonic in the alumina content, and a filter linearised at
the nominal point jumps to negative masses within a few steps.  There the first state
is searched on a grid of compositions and bath masses (:data:`START_GRID`), each filtered
over the first 8 hours, and the likeliest start taken per trajectory (:func:`searched_start`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ...compiled import CompiledModel, Smoothed
from ...physics import CellModel
from ...variables import STATES

__all__ = [
    "NOMINAL_STATE",
    "PRIOR_STD",
    "SETTLE_S",
    "START_GRID",
    "estimate_states",
    "prior",
    "searched_start",
    "start_is_searched",
]

#: a nominal operating point [kg x5, degC x3] and how far a cell may be from it (1 std) before anything is measured
NOMINAL_STATE = np.array([3000.0, 500.0, 1800.0, 14000.0, 10000.0, 970.0, 820.0, 580.0])
PRIOR_STD = np.array([1000.0, 150.0, 400.0, 2500.0, 150.0, 10.0, 40.0, 40.0])
#: process noise per step [state unit]: the model is trusted to this much per 10 s step
PROCESS_STD = 1e-7 * NOMINAL_STATE
#: first states tried where the composition is not sampled at the first step: Al2O3 and AlF3 mass
#: fractions of the bath and the bath mass [kg], spanning the simulated cells' range (config/config.yaml)
START_GRID = {"c2": (0.022, 0.03, 0.04, 0.05), "c3": (0.095, 0.11, 0.125), "bath": (12500.0, 14000.0, 15500.0)}
#: the span of data [s] over which each start of the grid is filtered and scored: a pot line's
#: 8-hourly hand samples fall in it once, and they are what rejects a wrong composition that the
#: voltage alone fits for an hour (a filter from there collapses onto it and is lost hours later)
START_SEARCH_S = 8 * 3600.0
#: how long [s] a filter from a searched start takes to settle: before, its innovations say how far the
#: start was off (the ledge and the bath's masses are placed by the first hand samples), not how wrong the
#: model is, and the channel tests leave them out.  Measured on the shipped plant cases' 12 cells, each
#: filtered with the model that made them: the bath temperature, voltage and AlF3 innovations exceed the
#: noise (up to 3.4, 1.75 and 13 times its variance) in the first 16 h of three cases; after it, they
#: pass on one of those and exceed it by 10-15 % on the other two
SETTLE_S = 2 * START_SEARCH_S


def prior(y: np.ndarray, channels: Sequence[str], start: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Prior mean (n, 8) and covariance (8, 8) of the first state, given the measurements y (n, K, C).

    A state measured at the first step starts there (with its prior std kept: the
    measurement update weighs it); with both fractions measured, the Al2O3 and AlF3
    masses start at the fractions of the nominal bath mass; ``start`` (n, 8), where given
    (:func:`searched_start`), replaces the mean.
    """
    n = y.shape[0]
    mean = np.tile(NOMINAL_STATE, (n, 1))
    first = {name: y[:, 0, c] for c, name in enumerate(channels)}
    for i, name in enumerate(STATES):
        if name in first:
            mean[:, i] = np.where(np.isfinite(first[name]), first[name], mean[:, i])
    bath = NOMINAL_STATE[1:4].sum()
    for name, index in (("c2", 1), ("c3", 2)):
        if name in first:
            mean[:, index] = np.where(np.isfinite(first[name]), first[name] * bath, mean[:, index])
    mean[:, 3] = bath - mean[:, 1] - mean[:, 2]
    return (mean if start is None else start), np.diag(PRIOR_STD**2)


def start_is_searched(y: np.ndarray, channels: Sequence[str]) -> bool:
    """Whether :func:`searched_start` searches the first states of y (n, K, C): not where both
    fractions are sampled at the first step of every trajectory (:func:`prior` places the masses)."""
    first = {name: y[:, 0, c] for c, name in enumerate(channels)}
    return not all(name in first and np.isfinite(first[name]).all() for name in ("c2", "c3"))


def searched_start(
    model: CellModel, y: np.ndarray, u: np.ndarray, channels: Sequence[str], noise_std: np.ndarray, dt: float
) -> np.ndarray | None:
    """The likeliest first state (n, 8) on :data:`START_GRID`, each filtered over the first
    :data:`START_SEARCH_S` of y (n, K, C); None where both fractions are sampled at the first step
    of every trajectory (:func:`prior` then places the masses).  A fraction sampled at the first
    step keeps its sample."""
    if not start_is_searched(y, channels):
        return None
    first = {name: y[:, 0, c] for c, name in enumerate(channels)}
    mean, cov = prior(y, channels)
    grid = np.array(np.meshgrid(*START_GRID.values(), indexing="ij")).reshape(3, -1).T
    missing = np.full(len(mean), np.nan)

    def kept(name: str, value: float) -> np.ndarray:
        return np.where(np.isfinite(first.get(name, missing)), first.get(name, missing), value)

    starts = np.repeat(mean[None], len(grid), axis=0)  # (G, n, 8)
    for g, (c2, c3, bath) in enumerate(grid):
        c2, c3 = kept("c2", c2), kept("c3", c3)
        starts[g, :, 1], starts[g, :, 2], starts[g, :, 3] = c2 * bath, c3 * bath, (1 - c2 - c3) * bath
    steps = min(y.shape[1], max(1, round(START_SEARCH_S / dt)))
    rows = len(grid) * len(mean)
    tiled = (np.tile(a[:, :steps], (len(grid), 1, 1)) for a in (y, u))
    result = CompiledModel(model, dt, channels).smooth(
        *tiled, starts.reshape(rows, 8), cov, PROCESS_STD, noise_std, backward=False
    )
    likelihood = np.nan_to_num(result.log_likelihood.reshape(len(grid), -1), nan=-np.inf)
    return starts[likelihood.argmax(0), np.arange(len(mean))]


def estimate_states(
    model: CellModel,
    y: np.ndarray,
    u: np.ndarray,
    channels: Sequence[str],
    noise_std: np.ndarray,
    dt: float,
    backward: bool = True,
    start: np.ndarray | None = None,
) -> Smoothed:
    """Smoothed states (n, K, 8) of ``model`` given measured channels y (n, K, C) (NaN: not sampled);
    ``backward`` False: the filter only (innovations and likelihood); ``start`` (n, 8): the prior
    mean of the first state (:func:`searched_start`), else :func:`prior`'s."""
    kernel = CompiledModel(model, dt, channels)
    return kernel.smooth(y, u, *prior(y, channels, start), PROCESS_STD, noise_std, backward=backward)
