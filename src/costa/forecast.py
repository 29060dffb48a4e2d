"""Rolling forecasts: a model predicts a whole test trajectory from its start, given the true inputs.

All trajectories (and all instances of a network type) advance together, one step
at a time (docs/model.md §6):

- networks (DDM, CoSTA): forward Euler, x_{k+1} = x_k + dt f(x_k, u_k), starting
  from the last of the first ``copied`` true samples (the authors copy 3);
- physics models (the PBM, a corrected model): RK4 with the same dt, from x_0.

States that leave the finite numbers are carried along (NaN stays NaN); the metrics
count them as blow-ups, so a diverging rollout never stops the others.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from .integrate import STEPPERS
from .physics import CellModel

if TYPE_CHECKING:
    from .models import NetworkModel

__all__ = ["rollout_networks", "rollout_physics"]


def _check(x_true: np.ndarray, u: np.ndarray, copied: int) -> None:
    if x_true.ndim != 3 or x_true.shape[-1] != 8 or u.shape != (*x_true.shape[:2], 5):
        raise ValueError(f"need x_true (T, K, 8) and u (T, K, 5), got {x_true.shape} and {u.shape}")
    if not 1 <= copied < x_true.shape[1]:
        raise ValueError(f"copied samples must be in [1, {x_true.shape[1] - 1}], got {copied}")


def _roll(step: Callable, start, u_steps: Callable[[int], object], out: np.ndarray, copied: int, to_numpy) -> None:
    x = start
    for k in range(copied - 1, out.shape[-2] - 1):
        x = step(x, u_steps(k))
        out[..., k + 1, :] = to_numpy(x)


def rollout_physics(
    model: CellModel, x_true: np.ndarray, u: np.ndarray, dt: float, copied: int = 1, method: str = "rk4"
) -> np.ndarray:
    """Forecasts (T, K, 8) of a physics model for T trajectories of K steps."""
    _check(x_true, u, copied)
    stepper = STEPPERS[method]
    out = np.empty_like(x_true, dtype=np.float64)
    out[:, :copied] = x_true[:, :copied]
    with np.errstate(all="ignore"):
        _roll(
            lambda x, uk: stepper(model.rhs, x, uk, dt),
            out[:, copied - 1].copy(),
            lambda k: u[:, k],
            out,
            copied,
            lambda x: x,
        )
    return out


def rollout_networks(model: NetworkModel, x_true: np.ndarray, u: np.ndarray, dt: float, copied: int = 3) -> np.ndarray:
    """Forecasts (E, T, K, 8) of every instance of a network model (forward Euler)."""
    import torch  # here: the physics rollouts' jobs start without torch

    with torch.inference_mode():
        return _roll_networks(torch, model, x_true, u, dt, copied)


def _roll_networks(torch, model: NetworkModel, x_true: np.ndarray, u: np.ndarray, dt: float, copied: int) -> np.ndarray:
    _check(x_true, u, copied)
    members = model.n_members
    out = np.empty((members, *x_true.shape), dtype=np.float64)
    out[:, :, :copied] = x_true[:, :copied]
    inputs = torch.from_numpy(np.ascontiguousarray(u))
    start = torch.from_numpy(out[:, :, copied - 1].copy())
    _roll(
        lambda x, uk: x + dt * model.rhs(x, uk),
        start,
        lambda k: inputs[:, k],
        out,
        copied,
        lambda x: x.numpy(),
    )
    return out
