"""Noise-robust residuals of a model against measured trajectories, and which equations disagree.

A plain forward difference (x_{k+1} - x_k)/dt amplifies measurement noise by
sqrt(2)/dt and turns every input impulse into a spike.  Instead, each step's
measured increment is compared with the model's increment over the same step (one
RK4 step from the measured state with the input held, as sampled data arise), and
the per-step differences are averaged under a smooth window of W steps:

    R_a = sum_s w_s [ x_{k+1} - RK4(x_k, u_k, dt) ] / dt,   k = aW + s.

This is a weak form with a Hann test function: the window's differences of the
noise telescope into a derivative of the weights, so the noise shrinks like W^-1.5
instead of growing like 1/dt.  An impulse u1 enters the model's step exactly, and
RK4 integrates the step's nonlinearity (an alumina feed moves c2 across the anode
effect's steep region within one step, where a trapezoid rule is visibly wrong).
The noise that remains in R is measured by Monte Carlo, window by window: noise of
the estimated size is added to the data and the change of R recorded.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ...integrate import rk4_step
from ...physics import CellModel
from ...variables import STATES

__all__ = [
    "EquationTest",
    "WeakForm",
    "equation_tests",
]


@dataclass(frozen=True)
class WeakForm:
    """Non-overlapping windows of ``window`` steps of ``dt`` seconds with Hann weights."""

    window: int
    dt: float

    def weights(self) -> np.ndarray:
        w = np.sin(np.pi * (np.arange(self.window) + 0.5) / self.window) ** 2
        return w / w.sum()

    def windows(self, steps: int) -> int:
        """How many whole windows fit in trajectories of ``steps`` samples."""
        return (steps - 1) // self.window

    def average(self, per_step: np.ndarray) -> np.ndarray:
        """Weighted window averages (n, A, ...) of per-step values (n, K-1, ...)."""
        n, k = per_step.shape[:2]
        a = k // self.window
        blocks = per_step[:, : a * self.window].reshape(n, a, self.window, *per_step.shape[2:])
        return np.einsum("naw...,w->na...", blocks, self.weights())

    def increments(self, model: CellModel, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The model's increment over each step (n, K-1, 8): one RK4 step from the measured state."""
        with np.errstate(all="ignore"):
            return rk4_step(model.rhs, x[:, :-1], u[:, :-1], self.dt) - x[:, :-1]

    def residual(self, model: CellModel, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Window-averaged rate residual R (n, A, 8) [state unit / s]: data minus model."""
        return self.average(np.diff(x, axis=1) - self.increments(model, x, u)) / self.dt

    def noise_scale(
        self,
        model: CellModel,
        x: np.ndarray,
        u: np.ndarray,
        noise: np.ndarray,
        rng: np.random.Generator,
        draws: int = 8,
    ) -> np.ndarray:
        """Std (n, A, 8) of the part of R that measurement noise of std ``noise`` (8,) causes.

        Noise matters far more in some windows than others: near the anode effect, a
        small error in the measured alumina fraction moves the bubble voltage a lot.
        Each window's scale comes from the Monte Carlo draws, and is never taken below
        the equation's overall scale (a few draws can underestimate a window).
        """
        base = self.residual(model, x, u)
        deviations = np.stack(
            [self.residual(model, x + rng.normal(size=x.shape) * noise, u) - base for _ in range(draws)]
        )
        deviations = np.nan_to_num(deviations, nan=np.inf, posinf=np.inf, neginf=np.inf)
        local = np.sqrt(np.mean(deviations**2, axis=0))
        overall = np.sqrt(np.median(local.reshape(-1, 8) ** 2, axis=0))
        return np.maximum(local, overall)


@dataclass(frozen=True)
class EquationTest:
    """How far one state equation's residual exceeds its noise."""

    state: str
    chi2_per_dof: float
    dof: int
    z: float
    flagged: bool
    residual_rms: float
    noise_rms: float

    @property
    def excess(self) -> float:
        """The fraction of residual variance that noise does not explain."""
        return self.chi2_per_dof - 1


def equation_tests(
    residual: np.ndarray,
    noise_rms: np.ndarray,
    z_threshold: float = 6.0,
    min_excess: float = 0.1,
    states: Sequence[str] = STATES,
) -> list[EquationTest]:
    """Test each equation's residual (n, A, 8) against its noise scale (n, A, 8) or (8,)
    (chi-square per degree of freedom).

    An equation is flagged when the excess is both significant (z above
    ``z_threshold`` standard errors of a chi-square mean) and material (above
    ``min_excess``: noise estimated from the data is itself uncertain by a few percent).
    """
    flat = residual.reshape(-1, residual.shape[-1])
    scale = np.broadcast_to(noise_rms, residual.shape).reshape(flat.shape)
    dof = flat.shape[0]
    chi2 = np.mean((flat / scale) ** 2, axis=0)
    z = (chi2 - 1) / np.sqrt(2 / dof)
    return [
        EquationTest(
            state=name,
            chi2_per_dof=float(chi2[i]),
            dof=dof,
            z=float(z[i]),
            flagged=bool(z[i] > z_threshold and chi2[i] - 1 > min_excess),
            residual_rms=float(np.sqrt(np.mean(flat[:, i] ** 2))),
            noise_rms=float(np.sqrt(np.mean(scale[:, i] ** 2))),
        )
        for i, name in enumerate(states)
    ]
