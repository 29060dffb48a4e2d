"""What to measure next: the measurements that would tell the best explanations apart.

Where a round ends undecided (explanations of different physics fit the measured channels
equally well) or unexplained, each explanation implies its own history of every channel
over the record: the smoothed states under its corrected model, on the record's own
inputs.  A measurement that samples a channel where those histories differ by many noise
stds would separate them.  Each instrument a pot line can add (:data:`costa.sensors.AVAILABLE`)
is scored by the expected separation of the first explanation from the nearest other one:
per cell sqrt(sum over its samples of (difference / noise std)^2), combined over the n cells
as sqrt(n x the median cell's square), in noise stds (a cell whose filter ran away under one
explanation would otherwise decide alone); the list is ranked by it.  A channel already
measured as often is left out (a logged pot voltage counts as the cell voltage: it is U plus
known constants).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ...observe import observe
from ...physics import CellModel
from ...sensors import AVAILABLE, Sensor
from ...variables import MEANING
from .observations import Observations

__all__ = ["Recommendation", "measure_next", "sampled_every"]


@dataclass(frozen=True)
class Recommendation:
    """Measuring ``channel`` every ``every_s`` seconds with noise ``noise`` would separate the
    explanations by ``separation`` noise stds (the first from the nearest other)."""

    channel: str
    every_s: float
    noise: float
    separation: float

    def describe(self) -> str:
        return (
            f"{self.channel} ({MEANING[self.channel]}) every {_interval(self.every_s)}, noise {self.noise:g}: "
            f"{self.separation:.1f} noise stds"
        )


def _interval(seconds: float) -> str:
    for unit, size in (("day", 86400), ("h", 3600), ("min", 60)):
        if seconds >= size and seconds % size == 0:
            count = int(seconds // size)
            return f"{count} {unit}" if unit != "day" else f"{count} day" + "s" * (count > 1)
    return f"{seconds:g} s"


def _separation(z: np.ndarray) -> float:
    """sqrt(n x median over the n cells of sum_k z_k^2) for differences z (n, samples) in noise stds."""
    per_cell = np.nansum(z**2, axis=1)
    return float(np.sqrt(len(per_cell) * np.median(per_cell)))


def sampled_every(obs: Observations) -> dict[str, float]:
    """Each measured channel's typical sampling interval [s] (the median spacing of its samples)."""
    every = {}
    for c, channel in enumerate(obs.channels):
        gaps = [np.diff(np.flatnonzero(np.isfinite(row))) for row in obs.y[..., c]]
        spacing = np.concatenate(gaps) if gaps else np.zeros(0)
        every[channel] = float(np.median(spacing)) * obs.dt if spacing.size else np.inf
    return every


def measure_next(
    explanations: Sequence[tuple[CellModel, np.ndarray]],
    obs: Observations,
    available: Sequence[Sensor] = AVAILABLE,
    top: int = 5,
) -> list[Recommendation]:
    """The ``top`` measurements that best separate the first of ``explanations`` (each a corrected
    model and its smoothed states (n, K, 8) on the record) from the others, best first; empty where
    there is nothing to separate it from."""
    if len(explanations) < 2:
        return []
    measured = sampled_every(obs)
    if "U_pot" in measured:  # the pot voltage is the cell voltage plus known constants: the same record
        measured["U_cell"] = min(measured["U_pot"], measured.get("U_cell", np.inf))
    channels = sorted({s.channel for s in available}, key=[s.channel for s in available].index)
    with np.errstate(all="ignore"):
        values = [observe(model, x, obs.u, channels) for model, x in explanations]
    found = []
    for sensor in available:
        if measured.get(sensor.channel, np.inf) <= sensor.every_s:
            continue
        stride = max(1, round(sensor.every_s / obs.dt))
        c = channels.index(sensor.channel)
        first = values[0][:, ::stride, c]
        separations = [_separation((first - other[:, ::stride, c]) / sensor.noise) for other in values[1:]]
        found.append(
            Recommendation(
                channel=sensor.channel, every_s=sensor.every_s, noise=sensor.noise, separation=float(min(separations))
            )
        )
    return sorted(found, key=lambda r: -r.separation)[:top]
