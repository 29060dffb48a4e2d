"""How much a hidden effect shows in a record: an oracle's bound on what the data can tell.

The record to learn from is simulated with the effect (the case's true model) and again without
it (the starting model) from the same initial states and the same inputs (replayed as logged,
so that a pot line's controllers do not answer the difference).  The signal is

    sqrt( sum over the measured samples of ((with - without) / noise std)^2 )

over every channel of the sensor set, at its sampling: a signal of 1 is one noise standard
deviation in one sample; a method that sees every sample and knows the effect's form finds it
only where the signal is several units.  An effect that drives the starting model's replay out
of the finite numbers has an infinite signal.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..discover.cases.shipped import HiddenEffectCase
from ..discover.cases.tables import case_noise, record_settings, simulated_cells
from ..discover.cases.unshipped import find_case
from ..observe import observe
from ..physics import model_from_config
from ..sensors import AT_TAPS, tap_starts
from ..simulate import simulate

__all__ = ["Replay", "signal"]


@dataclass(frozen=True)
class Replay:
    """Inputs (n, K, 5) given step by step, whatever the states (an open-loop operator)."""

    u: np.ndarray

    def inputs(self, x: np.ndarray, k: int) -> np.ndarray:
        return self.u[:, k]

    def bath_heat_taken(self) -> float:
        return 0.0


def signal(config: Mapping, case: str | HiddenEffectCase, sensors: str) -> dict[str, float]:
    """The signal of a case's record to learn from under a sensor set, and the samples it sums over."""
    case = find_case(case) if isinstance(case, str) else case
    sensor_set, settings = record_settings(config, sensors, case.name)
    true, start = case.models(model_from_config(config["physics"])[0])
    x, u = simulated_cells(config, case, sensors, "train")
    with np.errstate(all="ignore"):
        without = simulate(start, x[:, 0], Replay(u), settings, compiled=True).x
        difference = observe(true, x, u, sensor_set.channels) - observe(start, without, u, sensor_set.channels)
    noise = case_noise(true, x, u, sensor_set, case.noise)
    total, samples = 0.0, 0
    for c, sensor in enumerate(sensor_set.sensors):
        measured = _sampled(sensor.every_s, settings.dt, u)
        std = sensor.noise if sensor.noise is not None else noise[sensor.channel]
        scaled = difference[..., c][measured] / std
        total += float(np.sum(np.where(np.isfinite(scaled), scaled, np.inf) ** 2))
        samples += int(measured.sum())
    return {"signal": float(np.sqrt(total)), "samples": samples}


def _sampled(every_s, dt: float, u: np.ndarray) -> np.ndarray:
    """(n, K) the steps a channel is sampled at: every ``every_s`` seconds from the first, or at each tap."""
    if every_s == AT_TAPS:
        return tap_starts(u)
    every = max(1, int(round(every_s / dt)))
    return np.broadcast_to(np.arange(u.shape[1]) % every == 0, u.shape[:2])
