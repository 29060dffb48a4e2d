"""Which hypothesis explains measurements that see only part of the cell.

With some states never measured and others sampled hours apart, residuals per state
equation cannot be formed.  Instead each hypothesis' unknown delta(t) becomes a
random-walk state of the smoother (:mod:`.estimator`), beside the cell's eight
states: the data then say, through the marginal likelihood of the measured
channels, how much better the model explains them when that one delta may vary, and
the smoothed delta(t) is what the closed-form stage regresses on the physical
variables.

All hypotheses are filtered at once: each row of the batch carries its hypothesis'
index as an extra input, and one composed model evaluates every row with its own
delta (a hypothesis at delta = 0 leaves the model unchanged).  delta is scaled per
hypothesis so that one unit moves the most sensitive measured channel by one noise
std over a window of ``window`` steps; the random walk's step then reads in the same
units for every hypothesis.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..integrate import rk4_step
from ..observe import observe
from ..physics import CellModel
from .estimator import Smoothed, StateSpaceModel, smooth
from .hypotheses import Hypothesis
from .observed import NOMINAL_STATE, PROCESS_STD, prior
from .weak_form import estimate_noise

__all__ = [
    "Observations",
    "HypothesisScore",
    "channel_noise",
    "hypothesis_scales",
    "score_hypotheses",
    "smooth_hypothesis",
]

#: prior std of a hypothesis' scaled delta: a change of this many noise stds per window is not surprising
DELTA_PRIOR = 30.0


@dataclass(frozen=True)
class Observations:
    """Measured channels y (n, K, C) (NaN: not sampled), inputs u (n, K, 5), noise std (C,), step dt [s]."""

    y: np.ndarray
    u: np.ndarray
    channels: tuple[str, ...]
    noise: np.ndarray
    dt: float

    def subset(self, trajectories: np.ndarray | slice) -> Observations:
        return Observations(self.y[trajectories], self.u[trajectories], self.channels, self.noise, self.dt)


def channel_noise(y: np.ndarray, channels: Sequence[str], declared: Mapping[str, float]) -> np.ndarray:
    """Noise std per channel (C,): estimated from second differences where a channel is sampled at
    every step, else the declared sensor noise (a channel sampled hours apart cannot tell its noise
    from the process)."""
    noise = []
    for c, name in enumerate(channels):
        values = y[..., c]
        if np.isfinite(values).all():
            noise.append(float(estimate_noise(values[..., None])[0]))
        elif name in declared:
            noise.append(float(declared[name]))
        else:
            raise ValueError(
                f"channel {name!r} is not sampled at every step, so its noise cannot be estimated from the data; "
                "declare it in discovery.user_data.noise (the sensor's noise std, in the channel's unit)"
            )
    return np.array(noise)


def _composed(model: CellModel, hypotheses: Sequence[Hypothesis], which: np.ndarray, delta: np.ndarray) -> CellModel:
    """One model for a batch: row b is shifted by delta[b] along hypothesis which[b] (-1: none)."""
    for j, h in enumerate(hypotheses):
        rows = which == j
        if rows.any():
            model = h.shifted(model, np.where(rows, delta, 0.0))
    return model


def _space(
    model: CellModel, hypotheses: Sequence[Hypothesis], scales: np.ndarray, obs: Observations, walk: np.ndarray
) -> StateSpaceModel:
    """z = (x1..x8, scaled delta) for a batch of rows; the input carries u1..u5 and the row's
    hypothesis index; ``walk`` (rows,) is each row's random-walk std of delta per step.  One model
    is composed for the whole batch: hypothesis j reads the deltas of the rows it owns (0 elsewhere)."""
    current: dict[int, np.ndarray] = {}
    composed = model
    for j, h in enumerate(hypotheses):
        composed = h.driven(composed, lambda j=j: current[j])

    def split(z, u):
        which = u[:, 5].astype(int)
        for j, scale in enumerate(scales):
            current[j] = np.where(which == j, z[:, 8] * scale, 0.0)
        return z[:, :8], u[:, :5]

    def transition(z, u):
        x, inputs = split(z, u)
        return np.concatenate([rk4_step(composed.rhs, x, inputs, obs.dt), z[:, 8:]], axis=1)

    def measured(z, u):
        return observe(composed, *split(z, u), obs.channels)

    process = np.column_stack([np.tile(PROCESS_STD, (len(walk), 1)), walk])
    return StateSpaceModel(transition, measured, process, obs.noise, np.append(NOMINAL_STATE, 1.0))


def hypothesis_scales(
    model: CellModel, hypotheses: Sequence[Hypothesis], obs: Observations, window: int, probe: float = 1e-4
) -> np.ndarray:
    """The delta (H,) of each hypothesis that moves the most sensitive measured channel by one noise
    std over ``window`` steps, held from the first sample of each trajectory (0: no measured channel
    responds, the hypothesis is invisible to these sensors)."""
    x0, _ = prior(obs.y, obs.channels)
    u = obs.u[:, :window]
    h_count, n = len(hypotheses), x0.shape[0]
    which = np.repeat(np.arange(-1, h_count), n)
    x = np.tile(x0, (h_count + 1, 1))
    with np.errstate(all="ignore"):
        for k in range(window):
            shifted = _composed(model, hypotheses, which, np.full(which.shape, probe))
            x = rk4_step(shifted.rhs, x, np.tile(u[:, k], (h_count + 1, 1)), obs.dt)
        shifted = _composed(model, hypotheses, which, np.full(which.shape, probe))
        y = observe(shifted, x, np.tile(u[:, -1], (h_count + 1, 1)), obs.channels).reshape(h_count + 1, n, -1)
    response = np.nan_to_num(np.abs(y[1:] - y[0]) / probe / obs.noise)  # (H, n, C) noise stds per unit delta
    strongest = np.sqrt(np.mean(response**2, axis=1)).max(-1)
    return np.divide(1.0, strongest, out=np.zeros(h_count), where=strongest > 0)


@dataclass(frozen=True)
class HypothesisScore:
    """A hypothesis' log-likelihood gain over the model without it, at its best random-walk step."""

    hypothesis: Hypothesis
    scale: float
    walk: float
    log_likelihood_gain: float


def _rows(obs: Observations, hypotheses: Sequence[Hypothesis], walks: Sequence[float], scales: np.ndarray, null: bool):
    """Every (hypothesis, walk step, trajectory) row of a batch, with its inputs and prior; ``null``:
    rows of the model without any hypothesis first (index -1)."""
    n = obs.y.shape[0]
    pairs = [(-1, 0.0)] * null + [(j, w) for j in range(len(hypotheses)) for w in walks if scales[j] > 0]
    which = np.repeat([p[0] for p in pairs], n)
    reps = len(pairs)
    y = np.tile(obs.y, (reps, 1, 1))
    u = np.concatenate(
        [np.tile(obs.u, (reps, 1, 1)), np.broadcast_to(which[:, None, None], (n * reps, obs.u.shape[1], 1))], axis=-1
    )
    mean, cov = prior(obs.y, obs.channels)
    mean = np.concatenate([np.tile(mean, (reps, 1)), np.zeros((n * reps, 1))], axis=1)
    cov = np.tile(np.diag(np.append(np.diag(cov), DELTA_PRIOR**2)), (n * reps, 1, 1))
    cov[:, 8, 8] = np.where(which >= 0, DELTA_PRIOR**2, 0.0)
    return pairs, y, u, mean, cov


def _filter(model, hypotheses, scales, obs: Observations, window: int, walks, backward: bool):
    """The batch of :func:`_rows` through the smoother (with null rows when only filtering);
    returns the rows' (hypothesis, walk) pairs too."""
    pairs, y, u, mean, cov = _rows(obs, hypotheses, walks, scales, null=not backward)
    walk = np.repeat([w for _, w in pairs], obs.y.shape[0]) / np.sqrt(window)
    space = _space(model, hypotheses, scales, obs, walk)
    return pairs, smooth(space, y, u, mean, cov, backward=backward)


def score_hypotheses(
    model: CellModel,
    hypotheses: Sequence[Hypothesis],
    obs: Observations,
    window: int,
    walks: Sequence[float] = (0.3, 3.0),
) -> tuple[list[HypothesisScore], np.ndarray]:
    """Every hypothesis' log-likelihood gain (best over the random-walk steps ``walks``, in noise
    stds per window), best first, and the scales (H,)."""
    scales = hypothesis_scales(model, hypotheses, obs, window)
    n = obs.y.shape[0]
    pairs, result = _filter(model, hypotheses, scales, obs, window, walks, backward=False)
    totals = result.log_likelihood.reshape(len(pairs), n).sum(-1)
    base = totals[0]
    best: dict[int, tuple[float, float]] = {}
    for (j, walk), total in zip(pairs[1:], totals[1:], strict=True):
        if j not in best or total > best[j][0]:
            best[j] = (float(total), walk)
    scores = [HypothesisScore(hypotheses[j], float(scales[j]), walk, total - base) for j, (total, walk) in best.items()]
    return sorted(scores, key=lambda s: -s.log_likelihood_gain), scales


def smooth_hypothesis(model: CellModel, score: HypothesisScore, obs: Observations, window: int) -> Smoothed:
    """Smoothed states and delta (in the hypothesis' own unit) of one hypothesis at its walk step."""
    _, result = _filter(model, [score.hypothesis], np.array([score.scale]), obs, window, [score.walk], backward=True)
    result.mean[..., 8] *= score.scale
    result.std[..., 8] *= score.scale
    return result
