"""Many candidate closed forms scored in one pass of the filter: rows = candidate x cell.

A candidate is a hypothesis, a closed form (its features) and coefficient values.  The
filter of :mod:`.estimator` is vectorised over rows, so stacking every candidate's copy
of every cell as the rows of one batch scores them all for little more than the cost of
one: the per-step overhead of the model's numpy calls is shared, and only the arithmetic
grows.  Each row carries its coefficients as extra input columns (held over the record,
repeated with the row in the finite-difference Jacobians), so one batch may mix
coefficient values freely; candidates of different hypotheses or closed forms go in
one batch per (hypothesis, closed form).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ...integrate import rk4_step
from ...observe import observe
from ...physics import CellModel
from ..core.hypotheses import Hypothesis
from ..core.library import Feature
from .estimator import StateSpaceModel, smooth
from .observations import Observations
from .observed import NOMINAL_STATE, PROCESS_STD

__all__ = ["closed_form_likelihoods"]

INPUT_COLUMNS = 5


def closed_form_likelihoods(
    model: CellModel,
    hypothesis: Hypothesis,
    features: Sequence[Feature],
    coefficients: np.ndarray,
    obs: Observations,
) -> np.ndarray:
    """Log-likelihood (R, n) of the measured channels of every cell of ``obs`` under ``model``
    corrected by ``hypothesis`` with the closed form sum_k theta_k f_k, for each of the R rows of
    ``coefficients`` (R, P), all from the first states ``obs`` places the cells at.  Equal, to
    rounding, to filtering each candidate on its own (a trajectory whose filter is lost reads -inf)."""
    theta = np.atleast_2d(np.asarray(coefficients, dtype=float))
    candidates, terms = theta.shape
    if terms != len(features):
        raise ValueError(f"{terms} coefficients per candidate for {len(features)} features")
    current: dict[str, np.ndarray] = {}
    corrected = hypothesis.parametrised(model, features, lambda: current["theta"])

    def split(u: np.ndarray) -> np.ndarray:
        current["theta"] = u[:, INPUT_COLUMNS:]
        return u[:, :INPUT_COLUMNS]

    def transition(z: np.ndarray, u: np.ndarray) -> np.ndarray:
        inputs = split(u)
        return rk4_step(corrected.rhs, z, inputs, obs.dt)

    def measured(z: np.ndarray, u: np.ndarray) -> np.ndarray:
        inputs = split(u)
        return observe(corrected, z, inputs, obs.channels)

    n, steps = obs.y.shape[:2]
    space = StateSpaceModel(transition, measured, PROCESS_STD, obs.noise, NOMINAL_STATE)
    per_row = np.repeat(theta, n, axis=0)  # candidate-major: row r * n + i is candidate r on cell i
    u = np.concatenate(
        [np.tile(obs.u, (candidates, 1, 1)), np.broadcast_to(per_row[:, None, :], (candidates * n, steps, terms))],
        axis=-1,
    )
    mean, cov = obs.prior()
    result = smooth(space, np.tile(obs.y, (candidates, 1, 1)), u, np.tile(mean, (candidates, 1)), cov, backward=False)
    return np.where(np.isfinite(result.log_likelihood), result.log_likelihood, -np.inf).reshape(candidates, n)
