"""PySINDy's sparse regression of a model correction on this project's term library.

Both peers end here: given, at N samples, a target correction of each state rate,
PySINDy's STLSQ (optionally inside its bagging ``EnsembleOptimizer``) selects a sparse
sum of library terms per balance, each term a flow into the balance (kg/s or W) and
multiplied by the balance's rate per flow (1, alpha/m, beta/x1 or k17), so that the
coefficients are in physical units and the correction is a flow like ours.
The library (:func:`costa.discover.core.library.feature_library`, the flow library our
discovery starts from) is evaluated once to a matrix and handed to the optimizer, so
that the comparison is about the method, not the library.  Features and targets are
scaled by their standard deviations before the regression, so that one threshold
serves all eight balances; coefficients are reported in physical units.  The correction goes back as one
:class:`~costa.physics.BalanceTerm` per balance: an ordinary :class:`CellModel`.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pysindy as ps

from ..discover.core.hypotheses import Hypothesis
from ..discover.core.library import Feature, evaluate, feature_library
from ..physics import BALANCES, BalanceTerm, CellModel, CellVariables
from ..variables import STATES

__all__ = ["FEATURES", "SparseFit", "corrected_per_row", "design", "fit_sparse"]

#: the candidate terms of a flow into a balance (our discovery's first-round flow library)
FEATURES: list[Feature] = feature_library(relative=False)
_BALANCE_NAMES = list(BALANCES)


def design(start: CellModel, x: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The library evaluated at states x (..., 8) and inputs u (..., 5): (..., P)."""
    with np.errstate(all="ignore"):
        return evaluate(FEATURES, CellVariables(x, u), start.quantities(x, u), None)


@dataclass(frozen=True)
class SparseFit:
    """Coefficients (8, P) in kg/s or W per unit of each term, and how often bagging kept each."""

    coefficients: np.ndarray
    inclusion: np.ndarray

    @property
    def n_terms(self) -> int:
        return int(np.count_nonzero(self.coefficients))

    def terms(self) -> dict[str, list[dict]]:
        """Per changed state: its terms with coefficient and inclusion frequency."""
        found = {}
        for i, state in enumerate(STATES):
            kept = np.flatnonzero(self.coefficients[i])
            if kept.size:
                found[state] = [
                    {"term": FEATURES[j].name, "value": float(self.coefficients[i, j]),
                     "inclusion": float(self.inclusion[i, j])}
                    for j in kept
                ]  # fmt: skip
        return found

    def corrected(self, start: CellModel, name: str) -> CellModel:
        """``start`` with one flow per changed balance: sum_k xi_k theta_k."""
        return corrected_per_row(start, [self], None, name)


def corrected_per_row(start: CellModel, fits: Sequence[SparseFit], rows: int | None, name: str) -> CellModel:
    """``start`` corrected by each fit in turn on its own block of ``rows`` samples.

    With ``rows`` set, the model takes states (len(fits) * rows, ..., 8) and rows
    [g * rows, (g + 1) * rows) carry fit g's correction, so that a whole grid of fits is
    rolled out in one batch; with ``rows`` None there must be one fit, applied to any shape.
    """
    coefficients = np.stack([fit.coefficients for fit in fits])  # (G, 8, P)
    used = np.flatnonzero(np.abs(coefficients).sum((0, 1)))
    if not used.size:
        return start
    if rows is None:
        (coefficients,) = coefficients
    else:
        coefficients = np.repeat(coefficients, rows, axis=0)
    shared = _SharedFlows([FEATURES[j] for j in used], coefficients[..., used])
    terms = []
    for i, balance in enumerate(_BALANCE_NAMES):
        kept = np.flatnonzero(np.abs(coefficients[..., i, used]).reshape(-1, used.size).sum(0))
        if not kept.size:
            continue
        if rows is None:
            formula = Hypothesis.formula(
                [FEATURES[j] for j in used[kept]], [float(c) for c in coefficients[i, used[kept]]]
            )
        else:
            formula = f"one of {len(fits)} fits per block of {rows} rows"

        def flow(v, k, q, i=i):
            return shared(v, q)[..., i]

        terms.append(BalanceTerm(f"{name}_{balance}", formula, BALANCES[balance][1], {balance: 1.0}, flow))
    return start.with_terms(*terms, model_name=f"{start.name}+{name}")


class _SharedFlows:
    """Every balance's flow sum_k xi_k theta_k (..., 8), evaluated once per model evaluation
    (the last one is kept): the terms (..., T) against coefficients (8, T), or row by row
    against coefficients (rows, 8, T) for states (rows, ..., 8)."""

    def __init__(self, features: list[Feature], coefficients: np.ndarray):
        self.features, self.coefficients = features, coefficients
        self._samples, self._flows = None, None

    def __call__(self, v: CellVariables, q) -> np.ndarray:
        if v is not self._samples:
            terms = np.stack(np.broadcast_arrays(v.x1, *(f(v, q, None) for f in self.features))[1:], axis=-1)
            coefficients = self.coefficients
            if coefficients.ndim == 3:  # one row of fits per leading row of the states
                coefficients = coefficients.reshape(
                    len(coefficients), *(1,) * (terms.ndim - 2), *coefficients.shape[1:]
                )
            self._samples, self._flows = v, np.einsum("...t,...bt->...b", terms, coefficients)
        return self._flows


def fit_sparse(designs: np.ndarray, targets: np.ndarray, threshold: float, ensemble: int, seed: int) -> SparseFit:
    """STLSQ per balance: the state-i rate correction targets (N, 8) on that state's library
    designs (N, 8, P) (the terms times the balance's rate per flow), each column scaled by its
    standard deviation, so that a term is kept when its variation moves the target by at least
    ``threshold`` times the target's standard deviation.

    ``ensemble`` > 1: PySINDy's bagging ensemble of that many fits on N samples drawn with
    replacement; its median is the fit and the share of fits that keep a term its inclusion
    frequency.  PySINDy's bagging draws from numpy's global generator, seeded here with ``seed``.
    """
    coefficients = np.zeros((8, designs.shape[-1]))
    inclusion = np.zeros_like(coefficients)
    np.random.seed(seed % 2**32)  # noqa: NPY002 (PySINDy bags with numpy's global generator)
    for i in range(8):
        x, y = designs[:, i], targets[:, i]
        finite = np.isfinite(x).all(1) & np.isfinite(y)
        x, y = x[finite], y[finite]
        feature_scale = x.std(axis=0)
        feature_scale = np.where(feature_scale > 0, feature_scale, np.abs(x).max(axis=0, initial=0) + 1e-300)
        # a target that is essentially constant (a network's smooth output can be) is not scaled
        # up until its rounding wiggles pass the threshold
        target_scale = max(float(y.std()), 1e-3 * float(np.sqrt(np.mean(y**2)))) or 1.0
        stlsq = ps.STLSQ(threshold=threshold)
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", "Sparsity parameter is too big", UserWarning)
            if ensemble > 1:
                optimizer = ps.EnsembleOptimizer(stlsq, bagging=True, n_models=ensemble)
                optimizer.fit(x / feature_scale, y / target_scale)
                inclusion[i] = np.mean([np.abs(c[0]) > 0 for c in optimizer.coef_list], axis=0)
            else:
                optimizer = stlsq.fit(x / feature_scale, y / target_scale)
                inclusion[i] = np.abs(optimizer.coef_[0]) > 0
        coefficients[i] = optimizer.coef_[0] * target_scale / feature_scale
    return SparseFit(coefficients, inclusion)
