"""States and inputs spread over the cell's plausible operating range (for checks that must hold anywhere)."""

from __future__ import annotations

import numpy as np

__all__ = ["operating_points"]


def operating_points(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """States (n, 8) and inputs (n, 5) drawn uniformly over the ranges a running cell visits: a bath of
    9.5-17 t cryolite at 2.3-5 % Al2O3 and 9-13 % AlF3, 958-988 degC, a ledge of 1.6-5.5 t, a current of
    118-155 kA."""
    x4 = rng.uniform(9500, 17000, n)
    c2 = rng.uniform(0.023, 0.05, n)
    c3 = rng.uniform(0.09, 0.13, n)
    bath = x4 / (1 - c2 - c3)
    x = np.column_stack([
        rng.uniform(1600, 5500, n), c2 * bath, c3 * bath, x4, rng.uniform(9760, 10000, n),
        rng.uniform(958, 988, n), rng.uniform(745, 875, n), rng.uniform(490, 680, n),
    ])  # fmt: skip
    u = np.column_stack([
        rng.uniform(0, 22, n), rng.uniform(118000, 155000, n), rng.uniform(0, 8, n),
        rng.uniform(0, 9, n), rng.uniform(0.043, 0.057, n),
    ])  # fmt: skip
    return x, u
