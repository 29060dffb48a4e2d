"""What to measure next: the measurements that would tell the best explanations apart.

Where a round ends undecided (explanations of different physics fit the measured channels
equally well) or unexplained, each explanation implies its own history of every channel
over the record: the smoothed states under its corrected model, on the record's own
inputs.  A measurement that samples a channel where those histories differ by many noise
stds would separate them.  Each instrument a pot line can add (:data:`costa.sensors.AVAILABLE`)
is scored, for every pair of explanations, by their expected separation d: per cell
sqrt(sum over its samples of (difference / noise std)^2), combined over the n cells as
sqrt(n x the median cell's square), in noise stds (a cell whose filter ran away under one
explanation would otherwise decide alone).

The list is ranked by the chance the added record decides: where explanation i is the truth, its
BIC lead over j from the new samples is normal with mean d^2 and std 2 d (twice the
log-likelihood ratio of two known means), so it clears the naming margin m with probability
Phi((d^2 - m) / (2 d)); the chance of a name is the mean over the explanations, each taken as the
truth in turn (they fit the record alike), of the product over its rivals.  The separation of the
first explanation from its nearest rival is reported beside it, the number a closed loop checks.
Only samples after the filter settles from a searched start count (:attr:`.Observations.settling_steps`,
as in the channel tests): before it, the explanations' histories differ by their starts, which each
would fit again to the new samples.  A channel already measured as often is left out (a logged pot
voltage counts as the cell voltage: it is U plus known constants), and so is an instrument no more
likely to decide than a slower one of the same channel.

Where no instrument is left to add (a record that samples every channel as often as a pot line can),
the recommendation is more of the same: the smallest multiple of the record (:data:`MULTIPLES`, more
cells or hours of the channels it measures) whose samples would name one with probability at least a
half, scored alike on the measured channels (d grows with the square root of the multiple), or the
largest multiple and its chance, which then says that no practical record of these channels decides.
None where the record itself already would: then its explanations are not held level by the margin but
by another rule (the verdict says which), which more of the same does not lift.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import norm

from ...observe import observe
from ...physics import CellModel
from ...sensors import AVAILABLE, Sensor
from ...variables import MEANING
from .observations import Observations

__all__ = ["MULTIPLES", "Recommendation", "decides", "measure_next", "sampled_every", "separating", "to_separate"]

#: the multiples of a record that more of the same is scored at (its cells and hours together)
MULTIPLES = (2, 4, 8, 16, 32)


@dataclass(frozen=True)
class Recommendation:
    """Measuring ``channel`` every ``every_s`` seconds with noise ``noise`` (or, ``channel`` None, a record
    ``multiple`` times this one, of the channels it measures) would separate the first explanation, ``best``,
    from its nearest rival, ``rival`` (hypothesis keys), by ``separation`` noise stds, and name one of the
    ``explanations`` (every key compared) with probability ``decides`` where one of them is the truth."""

    channel: str | None
    every_s: float | None
    noise: float | None
    separation: float
    best: str
    rival: str
    decides: float
    explanations: tuple[str, ...]
    multiple: int = 1

    def describe(self) -> str:
        what = (
            f"a record {self.multiple} times this one (more cells or hours of the channels it measures)"
            if self.channel is None
            else f"{self.channel} ({MEANING[self.channel]}) every {_interval(self.every_s)}, noise {self.noise:g}"
        )
        return f"{what}: {self.separation:.1f} noise stds from {self.rival}, a name with probability {self.decides:.2f}"


def separating(recommended: Sequence[Recommendation]) -> str:
    """The verdict's words on what would separate a round's explanations: the top recommendation where it names
    one with probability at least a half, else that none listed is likely to (nothing where none is listed)."""
    if not recommended:
        return ""
    top = recommended[0]
    if top.decides >= 0.5:
        return f"; measuring {top.describe()} would separate them"
    return f"; no measurement listed is likely to separate them (the likeliest: {top.describe()})"


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


def decides(d: np.ndarray, margin: float) -> float:
    """The chance that samples separating explanations pairwise by ``d`` (k, k) noise stds name one: the
    mean over i of the product over j != i of Phi((d_ij^2 - margin) / (2 d_ij)), ``margin`` in BIC."""
    with np.errstate(divide="ignore", invalid="ignore"):
        clears = norm.cdf((d**2 - margin) / (2 * d))
    clears = np.where(np.isfinite(clears), clears, 0.0)
    np.fill_diagonal(clears, 1.0)
    return float(np.prod(clears, axis=1).mean())


def sampled_every(obs: Observations) -> dict[str, float]:
    """Each measured channel's typical sampling interval [s] (the median spacing of its samples)."""
    every = {}
    for c, channel in enumerate(obs.channels):
        gaps = [np.diff(np.flatnonzero(np.isfinite(row))) for row in obs.y[..., c]]
        spacing = np.concatenate(gaps) if gaps else np.zeros(0)
        every[channel] = float(np.median(spacing)) * obs.dt if spacing.size else np.inf
    return every


def to_separate(chosen, rivals: Sequence, ranking: Sequence, count: int = 3) -> list:
    """The fitted candidates a measurement should tell apart: the chosen one and its fitted rivals (a rival
    that screened ahead may have no closed form), or, where it has none (its outcome undecided for another
    reason: hypotheses not fitted, a channel left), the chosen one and the next best fitted, ``count`` in all."""
    fitted = [c for c in ranking if c is not chosen and c.corrected is not None and c.states is not None]
    rivals = [r for r in rivals if any(r is c for c in fitted)]
    return [chosen, *rivals] if rivals else [chosen, *fitted[: count - 1]]


def measure_next(
    explanations: Sequence[tuple[str, CellModel, np.ndarray]],
    obs: Observations,
    margin: float,
    available: Sequence[Sensor] = AVAILABLE,
    top: int = 5,
) -> list[Recommendation]:
    """The ``top`` measurements most likely to name one of ``explanations`` (each a hypothesis key, its
    corrected model and its smoothed states (n, K, 8) on the record), best first, with the naming
    ``margin`` [BIC]; where no instrument is left to add, more of the same (:func:`_longer_record`); empty
    where there is nothing to separate the first from."""
    if len(explanations) < 2:
        return []
    keys = tuple(key for key, _, _ in explanations)
    measured = sampled_every(obs)
    if "U_pot" in measured:  # the pot voltage is the cell voltage plus known constants: the same record
        measured["U_cell"] = min(measured["U_pot"], measured.get("U_cell", np.inf))
    addable = [s for s in available if measured.get(s.channel, np.inf) > s.every_s]
    if not addable:
        longer = _longer_record(keys, [(model, x) for _, model, x in explanations], obs, margin)
        return [longer] if longer is not None else []
    channels = sorted({s.channel for s in addable}, key=[s.channel for s in addable].index)
    with np.errstate(all="ignore"):
        values = [observe(model, x, obs.u, channels) for _, model, x in explanations]
    found = []
    for sensor in addable:
        stride = max(1, round(sensor.every_s / obs.dt))
        c = channels.index(sensor.channel)
        sampled = [v[:, obs.settling_steps :: stride, c] / sensor.noise for v in values]
        d = np.array([[_separation(a - b) for b in sampled] for a in sampled])
        nearest = 1 + int(np.argmin(d[0, 1:]))
        found.append(
            Recommendation(
                channel=sensor.channel, every_s=sensor.every_s, noise=sensor.noise, separation=float(d[0, nearest]),
                best=keys[0], rival=keys[nearest], decides=decides(d, margin), explanations=keys,
            )
        )  # fmt: skip
    return _undominated(sorted(found, key=lambda r: (-r.decides, -r.separation, -r.every_s)))[:top]


def _longer_record(
    keys: tuple[str, ...], explanations: Sequence[tuple[CellModel, np.ndarray]], obs: Observations, margin: float
) -> Recommendation | None:
    """More of the same: the separation of ``explanations`` (the models and states of ``keys``) on the channels the record measures, at its own
    samples after the filter settles (per cell, summed over the channels), and the smallest of :data:`MULTIPLES`
    whose record would name one with probability at least a half (else the largest); None where this record
    already would."""
    with np.errstate(all="ignore"):
        values = [observe(model, x, obs.u, obs.channels) for model, x in explanations]
    settled = obs.y[:, obs.settling_steps :]
    sampled = [np.where(np.isfinite(settled), v[:, obs.settling_steps :] / obs.noise, np.nan) for v in values]
    d = np.array([[_separation((a - b).reshape(len(a), -1)) for b in sampled] for a in sampled])
    if decides(d, margin) >= 0.5:
        return None
    nearest = 1 + int(np.argmin(d[0, 1:]))
    chances = [decides(d * np.sqrt(k), margin) for k in MULTIPLES]
    k = next((i for i, chance in enumerate(chances) if chance >= 0.5), len(MULTIPLES) - 1)
    return Recommendation(
        channel=None, every_s=None, noise=None, separation=float(d[0, nearest] * np.sqrt(MULTIPLES[k])), best=keys[0],
        rival=keys[nearest], decides=chances[k], explanations=keys, multiple=MULTIPLES[k],
    )  # fmt: skip


def _undominated(ranked: Sequence[Recommendation]) -> list[Recommendation]:
    """``ranked`` without the instruments a slower one of the same channel, ranked before, matches."""
    kept: list[Recommendation] = []
    for r in ranked:
        if not any(k.channel == r.channel and k.every_s >= r.every_s for k in kept):
            kept.append(r)
    return kept
