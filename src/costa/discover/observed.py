"""The cell model seen through its sensors: a state-space model for the estimator, and its prior.

The states x1..x8 advance by one RK4 step of the model per sample (the inputs held,
as the data arise); the measured channels (:mod:`costa.sensors`) are read from the
states, and the cell voltage from the model's own parts, so a model whose voltage
is wrong shows it in the ``U_cell`` channel.  Unmeasured states start from a wide
prior around a nominal operating point; measured ones from their first sample.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..integrate import rk4_step
from ..observe import observe
from ..physics import CellModel
from ..variables import STATES
from .estimator import Smoothed, StateSpaceModel, smooth

__all__ = ["NOMINAL_STATE", "PRIOR_STD", "cell_state_space", "estimate_states", "prior"]

#: a nominal operating point [kg x5, degC x3] and how far a cell may be from it (1 std) before anything is measured
NOMINAL_STATE = np.array([3000.0, 500.0, 1800.0, 14000.0, 10000.0, 970.0, 820.0, 580.0])
PRIOR_STD = np.array([1000.0, 150.0, 400.0, 2500.0, 150.0, 10.0, 40.0, 40.0])
#: process noise per step [state unit]: the model is trusted to this much per 10 s step
PROCESS_STD = 1e-7 * NOMINAL_STATE


def cell_state_space(
    model: CellModel,
    channels: Sequence[str],
    noise_std: np.ndarray,
    dt: float,
    process_std: np.ndarray = PROCESS_STD,
) -> StateSpaceModel:
    """``model`` stepped by RK4 over ``dt`` [s], observed through ``channels`` with noise ``noise_std`` (C,)."""
    channels = tuple(channels)
    return StateSpaceModel(
        transition=lambda z, u: rk4_step(model.rhs, z, u, dt),
        observe=lambda z, u: observe(model, z, u, channels),
        process_std=np.asarray(process_std, dtype=float),
        noise_std=np.asarray(noise_std, dtype=float),
        scale=NOMINAL_STATE,
    )


def prior(y: np.ndarray, channels: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """Prior mean (n, 8) and covariance (8, 8) of the first state, given the measurements y (n, K, C).

    A state measured at the first step starts there (with its prior std kept: the
    measurement update weighs it); with both fractions measured, the Al2O3 and AlF3
    masses start at the fractions of the nominal bath mass.
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
    return mean, np.diag(PRIOR_STD**2)


def estimate_states(
    model: CellModel,
    y: np.ndarray,
    u: np.ndarray,
    channels: Sequence[str],
    noise_std: np.ndarray,
    dt: float,
    backward: bool = True,
) -> Smoothed:
    """Smoothed states (n, K, 8) of ``model`` given measured channels y (n, K, C) (NaN: not sampled);
    ``backward`` False: the filter only (innovations and likelihood)."""
    return smooth(cell_state_space(model, channels, noise_std, dt), y, u, *prior(y, channels), backward=backward)
