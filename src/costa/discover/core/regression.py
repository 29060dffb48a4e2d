"""Sparse regression of a standardised residual on candidate terms, with a grouped bootstrap.

The linear problem is z ~ D xi, with rows = (window, equation) pairs, both sides
divided by the equation's noise level.  Everything works on Gram matrices
G = D^T D, b = D^T z, z^T z, summed per *group* of windows (a block of a
trajectory): a bootstrap resample of groups is then a weighted sum of the groups'
Gram matrices, so hundreds of resamples cost milliseconds.

Selection is forward stepwise: add the term that lowers the residual sum of squares
most, as long as it lowers the Bayesian information criterion
BIC = n ln(RSS / n) + k ln(n) by at least ``min_gain`` (a "very strong" margin,
since rows within a window share noise and n overstates the evidence).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "Fit",
    "GramSystem",
    "coefficient_samples",
    "independent_columns",
    "resample_weights",
    "selected_in_half",
    "selection_frequency",
    "solve_subset",
    "stepwise",
]


@dataclass(frozen=True)
class GramSystem:
    """Per-group normal equations: G (g, P, P), b (g, P), zz (g,), rows (g,)."""

    G: np.ndarray
    b: np.ndarray
    zz: np.ndarray
    rows: np.ndarray

    @classmethod
    def from_design(cls, design: np.ndarray, target: np.ndarray, groups: np.ndarray) -> GramSystem:
        """design (N, P), target (N,), groups (N,) integer labels 0..g-1."""
        count = int(groups.max()) + 1
        G = np.zeros((count, design.shape[1], design.shape[1]))
        b = np.zeros((count, design.shape[1]))
        zz, rows = np.zeros(count), np.zeros(count)
        for g in range(count):
            rows_g = groups == g
            d, z = design[rows_g], target[rows_g]
            G[g], b[g], zz[g], rows[g] = d.T @ d, d.T @ z, z @ z, rows_g.sum()
        return cls(G, b, zz, rows)

    def totals(self, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The weighted sums for every row of ``weights`` (R, g) at once: G (R, P, P), b (R, P),
        zz (R,), rows (R,)."""
        G = (weights @ self.G.reshape(len(self.zz), -1)).reshape(len(weights), *self.G.shape[1:])
        return G, weights @ self.b, weights @ self.zz, weights @ self.rows

    def total(self, weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, float, float]:
        w = np.ones(len(self.zz)) if weights is None else weights
        return (
            np.tensordot(w, self.G, axes=1),
            w @ self.b,
            float(w @ self.zz),
            float(w @ self.rows),
        )


@dataclass(frozen=True)
class Fit:
    """A selected set of terms, their coefficients and the fit's statistics."""

    selected: tuple[int, ...]
    coefficients: np.ndarray
    rss: float
    rss_baseline: float
    rows: float
    bic_gain: float  # BIC(no correction) - BIC(this fit): how much better than nothing

    @property
    def explained(self) -> float:
        """Fraction of the standardised residual sum of squares the fit removes."""
        return 1 - self.rss / self.rss_baseline if self.rss_baseline > 0 else 0.0


def solve_subset(G: np.ndarray, b: np.ndarray, subset: Sequence[int]) -> np.ndarray:
    """Least-squares coefficients of a subset of terms from the normal equations (columns scaled)."""
    index = list(subset)
    if not index:
        return np.zeros(0)
    norm = np.sqrt(np.diag(G)[index])
    norm = np.where(norm > 0, norm, 1.0)
    scaled = G[np.ix_(index, index)] / np.outer(norm, norm)
    return np.linalg.lstsq(scaled, b[index] / norm, rcond=None)[0] / norm


def stepwise(
    G: np.ndarray,
    b: np.ndarray,
    zz: float,
    rows: float,
    max_terms: int = 6,
    min_gain: float = 10.0,
    collinear: float = 1e-9,
) -> Fit:
    """Forward selection by BIC.

    With the current terms S, adding term j lowers the residual sum of squares by
    (b_j - G_jS G_SS^-1 b_S)^2 / (G_jj - G_jS G_SS^-1 G_Sj); both are computed for every
    candidate at once.  A candidate whose remaining variance (the denominator) is below
    ``collinear`` of its own is (nearly) a combination of the chosen terms and is skipped.
    """
    # work with unit-norm columns: raw terms differ in scale by many orders of magnitude
    norm = np.sqrt(np.diag(G))
    norm = np.where(norm > 0, norm, 1.0)
    G, b = G / np.outer(norm, norm), b / norm
    selected: list[int] = []
    diagonal = np.diag(G).copy()
    explained = 0.0

    def bic(explained_ss: float, k: int) -> float:
        return rows * np.log(max(zz - explained_ss, 1e-300) / rows) + k * np.log(rows)

    baseline = current = bic(0.0, 0)
    while len(selected) < max_terms:
        if selected:
            inverse = np.linalg.inv(G[np.ix_(selected, selected)])
            cross = G[selected]  # (k, P)
            numerator = b - cross.T @ (inverse @ b[selected])
            denominator = diagonal - np.einsum("kp,kl,lp->p", cross, inverse, cross)
        else:
            numerator, denominator = b.copy(), diagonal.copy()
        usable = denominator > collinear * np.maximum(diagonal, 1e-300)
        usable[selected] = False
        if not usable.any():
            break
        gains = np.where(usable, numerator**2 / np.where(usable, denominator, 1.0), -np.inf)
        best = int(np.argmax(gains))
        candidate = bic(explained + gains[best], len(selected) + 1)
        if candidate > current - min_gain:
            break
        selected.append(best)
        explained += gains[best]
        current = candidate
    coefficients = solve_subset(G, b, selected)
    explained = float(b[selected] @ coefficients) if selected else 0.0
    coefficients = coefficients / norm[selected] if selected else coefficients
    return Fit(
        selected=tuple(selected),
        coefficients=coefficients,
        rss=zz - explained,
        rss_baseline=zz,
        rows=rows,
        bic_gain=baseline - bic(explained, len(selected)),
    )


def resample_weights(groups: int, resamples: int, rng: np.random.Generator) -> np.ndarray:
    """(resamples, groups) counts: each resample draws ``groups`` groups with replacement."""
    return np.stack([np.bincount(rng.integers(0, groups, groups), minlength=groups) for _ in range(resamples)]).astype(
        float
    )


def selection_frequency(system: GramSystem, weights: np.ndarray, **selection) -> np.ndarray:
    """How often forward selection picks each term (P,) over the resamples ``weights`` (R, g)."""
    inclusion = np.zeros(system.G.shape[1])
    for G, b, zz, rows in zip(*system.totals(weights), strict=True):
        inclusion[list(stepwise(G, b, float(zz), float(rows), **selection).selected)] += 1
    return inclusion / len(weights)


def selected_in_half(
    system: GramSystem, resamples: int, rng: np.random.Generator, **selection
) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """The bootstrap of both routes' closed forms: ``resamples`` resamples of the groups (weights (R, g)),
    how often forward selection picks each term over them (P,), and the terms it picks in at least half."""
    weights = resample_weights(len(system.zz), resamples, rng)
    inclusion = selection_frequency(system, weights, **selection)
    return weights, inclusion, [i for i in range(len(inclusion)) if inclusion[i] >= 0.5]


def coefficient_samples(system: GramSystem, chosen: Sequence[int], weights: np.ndarray) -> np.ndarray:
    """The ``chosen`` terms' coefficients refitted on each resample of ``weights`` (R, g): (R, k)."""
    G, b, _, _ = system.totals(weights)
    return np.stack([solve_subset(G_r, b_r, chosen) for G_r, b_r in zip(G, b, strict=True)])


def independent_columns(columns: np.ndarray, tolerance: float = 1e-8) -> list[int]:
    """Indices of columns that are not zero and not (nearly) a multiple of an earlier one."""
    norms = np.linalg.norm(columns, axis=0)
    kept: list[int] = []
    for j in np.flatnonzero(norms > 0):
        unit = columns[:, j] / norms[j]
        if all(abs(unit @ columns[:, i] / norms[i]) < 1 - tolerance for i in kept):
            kept.append(int(j))
    return kept
