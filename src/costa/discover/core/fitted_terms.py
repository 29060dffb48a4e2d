"""A fitted closed form's terms and their bootstrap intervals: which terms are kept, and how
they are reported (:data:`KEEP_LEVEL`)."""

from __future__ import annotations

import numpy as np

from .hypotheses import Hypothesis
from .library import Feature

__all__ = ["KEEP_LEVEL", "FittedTerms", "percentile_intervals", "weakest_term"]

#: a term is kept only if its bootstrap interval at this level excludes zero (the findings
#: report it and the 95 % interval, which lies inside it)
KEEP_LEVEL = 0.99


class FittedTerms:
    """What a fitted closed form offers to read: ``features``, ``coefficients`` and bootstrap
    ``samples`` (resamples, terms) give the formula and each term's interval."""

    features: list[Feature]
    coefficients: np.ndarray
    samples: np.ndarray | None

    @property
    def formula(self) -> str:
        return Hypothesis.formula(self.features, self.coefficients)

    def intervals(self, level: float) -> list[tuple[float, float]]:
        """Each term's bootstrap interval at ``level`` (a percentile interval of ``samples``)."""
        return percentile_intervals(self.samples, level)


def percentile_intervals(samples: np.ndarray, level: float) -> list[tuple[float, float]]:
    """Each column's (resamples x terms) percentile interval at ``level``."""
    low, high = np.quantile(samples, [(1 - level) / 2, (1 + level) / 2], axis=0)
    return [(float(lo), float(hi)) for lo, hi in zip(low, high, strict=True)]


def weakest_term(samples: np.ndarray, level: float) -> int | None:
    """The term (column of ``samples``, resamples x terms) whose ``level`` interval covers zero
    with the most resamples on the other side of zero from the median; None if no interval does."""
    if not samples.shape[1]:
        return None
    low, high = np.quantile(samples, [(1 - level) / 2, (1 + level) / 2], axis=0)
    covers = (low <= 0) & (high >= 0)
    if not covers.any():
        return None
    across = np.mean(np.sign(samples) != np.sign(np.median(samples, axis=0)), axis=0)
    return int(np.argmax(np.where(covers, across, -1.0)))
