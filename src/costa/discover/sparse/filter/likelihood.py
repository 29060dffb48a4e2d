"""Which hypothesis explains measurements that see only part of the cell.

With some states never measured and others sampled hours apart, residuals per state
equation cannot be formed.  Instead each hypothesis' unknown delta(t) becomes a
random-walk state of the smoother (:mod:`..estimator`), beside the cell's eight
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

import dataclasses
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from ....compiled import CompiledModel, Parameters, Smoothed, compile_side_by_side
from ....physics import CellModel
from ...core.hypotheses import Hypothesis
from ...core.library import Feature
from ..observations import Observations
from ..observed import PROCESS_STD
from ..rounds import HypothesisScore, best_first, likelihood_gains

__all__ = [
    "hypothesis_scales",
    "mostly_lost",
    "score_hypotheses",
    "refine_coefficients",
    "smooth_hypothesis",
]

#: prior std of a hypothesis' scaled delta: a change of this many noise stds per window is not surprising
DELTA_PRIOR = 30.0


def _responses(
    model: CellModel, hypotheses: Sequence[Hypothesis], which: np.ndarray, delta: float,
    x: np.ndarray, u: np.ndarray, obs: Observations,
) -> np.ndarray:  # fmt: skip
    """The measured channels (copies, rows, C) after simulating stacked copies of the states x (rows, 8)
    under the inputs u (rows, steps, 5), one row block per entry of ``which`` (rows of copy c shifted by
    ``delta`` along hypothesis which[c]; -1: none)."""
    present = [j for j in range(len(hypotheses)) if (which == j).any()]
    deltas = [Parameters() for _ in present]
    shifted = model
    for j, parameter in zip(present, deltas, strict=True):
        shifted = hypotheses[j].driven(shifted, parameter)
    kernel = CompiledModel(shifted, obs.dt, obs.channels, deltas, derivatives=False)
    values = [np.where(which == j, delta, 0.0) for j in present]
    copies = len(which) // len(x)
    inputs = np.tile(u, (copies, 1, 1))
    end = kernel.march(np.tile(x, (copies, 1)), inputs, *values, record=None)
    return kernel.sense(end, inputs[:, -1], *values).reshape(copies, len(x), -1)


def hypothesis_scales(
    model: CellModel,
    hypotheses: Sequence[Hypothesis],
    obs: Observations,
    window: int,
    states: np.ndarray,
    probe: float = 1e-4,
) -> np.ndarray:
    """The delta (H,) of each hypothesis that moves the most sensitive measured channel by one noise
    std over ``window`` steps, held from the first sample of each trajectory.  A hypothesis no
    channel responds to there (an input that acts now and then, a tapping) is probed in every
    window of the data instead, from the estimated ``states`` (n, K, 8) at its start, and its
    response averaged (root mean square) over the windows.  0: no measured channel responds,
    the hypothesis is invisible to these sensors."""

    def strongest(which_rows, x, u):
        y = _responses(model, hypotheses, which=which_rows, delta=probe, x=x, u=u, obs=obs)
        response = np.nan_to_num(np.abs(y[1:] - y[0]) / probe / obs.noise)  # noise stds per unit delta
        return np.sqrt(np.mean(response**2, axis=1)).max(-1)

    x0, _ = obs.prior()
    h_count = len(hypotheses)
    size = strongest(np.repeat(np.arange(-1, h_count), len(x0)), x0, obs.u[:, :window])
    silent = np.flatnonzero(size == 0)
    if len(silent):
        n, steps = obs.y.shape[:2]
        starts = np.arange(0, steps - window + 1, window)
        x = states[:, starts].reshape(-1, 8)
        u = obs.u[:, starts[:, None] + np.arange(window)].reshape(len(x), window, -1)
        which = np.repeat(np.concatenate([[-1], silent]), len(x))
        size[silent] = strongest(which, x, u)
    return np.divide(1.0, size, out=np.zeros(h_count), where=size > 0)


def _rows(obs: Observations, pairs: Sequence[tuple[int, float]]):
    """The (hypothesis, walk step) ``pairs``' rows, a trajectory each: their measurements, inputs and
    prior (the delta's: none for the model without a hypothesis, index -1)."""
    n, reps = obs.y.shape[0], len(pairs)
    which = np.repeat([p[0] for p in pairs], n)
    y, u = np.tile(obs.y, (reps, 1, 1)), np.tile(obs.u, (reps, 1, 1))
    mean, cov = obs.prior()
    mean = np.concatenate([np.tile(mean, (reps, 1)), np.zeros((n * reps, 1))], axis=1)
    cov = np.tile(np.diag(np.append(np.diag(cov), DELTA_PRIOR**2)), (n * reps, 1, 1))
    cov[:, 8, 8] = np.where(which >= 0, DELTA_PRIOR**2, 0.0)
    return y, u, mean, cov


def _filter(model, hypotheses, scales, obs: Observations, window: int, walks, backward: bool):
    """Every (hypothesis, walk step, trajectory) row through the smoother, with the model's own rows
    (no hypothesis, index -1) first when only filtering; returns the rows' (hypothesis, walk) pairs
    in their order.  z = (x1..x8, scaled delta), each row's delta a random walk of its own step.

    The rows of each kind of hypothesis go through one model composed of that kind's hypotheses,
    hypothesis j reading a delta of its own: the scaled delta of the rows it owns, 0 on the others
    (row b's mixing holds scale j at j = which[b] alone).  A row's numbers are those of the model
    corrected by its own hypothesis alone; a kind's model is the cost of a row (the 58 hypotheses'
    corrections composed at once doubled it)."""
    pairs = [(-1, 0.0)] * (not backward) + [(j, w) for j in range(len(hypotheses)) for w in walks if scales[j] > 0]
    kinds = {j: hypotheses[j].kind if j >= 0 else None for j, _ in pairs}
    pairs = sorted(pairs, key=lambda p: list(dict.fromkeys(kinds.values())).index(kinds[p[0]]))  # stable: by kind
    n, batches = obs.y.shape[0], []
    for kind in dict.fromkeys(kinds[j] for j, _ in pairs):
        group = [p for p in pairs if kinds[p[0]] == kind]
        present = sorted({j for j, _ in group if j >= 0})
        deltas = [Parameters() for _ in present]
        composed = model
        for j, delta in zip(present, deltas, strict=True):
            composed = hypotheses[j].driven(composed, delta)
        which = np.repeat([j for j, _ in group], n)
        mixing = np.zeros((len(which), len(present), 1))
        owned = np.flatnonzero(which >= 0)
        mixing[owned, np.searchsorted(present, which[owned]), 0] = scales[which[owned]]
        walk = np.repeat([w for _, w in group], n) / np.sqrt(window)
        process = np.column_stack([np.tile(PROCESS_STD, (len(walk), 1)), walk])
        kernel = CompiledModel(composed, obs.dt, obs.channels, deltas, augmented=1, compiled=False)
        batches.append((kernel, group, process, mixing))
    compile_side_by_side(kernel for kernel, *_ in batches)
    parts = [
        kernel.smooth(*_rows(obs, group), process, obs.noise, mixing, backward=backward)
        for kernel, group, process, mixing in batches
    ]
    fields = ("mean", "std", "innovation", "log_likelihood", "final_cov")
    return pairs, Smoothed(*(np.concatenate([getattr(part, f) for part in parts]) for f in fields))


def score_hypotheses(
    model: CellModel,
    hypotheses: Sequence[Hypothesis],
    obs: Observations,
    window: int,
    states: np.ndarray,
    walks: Sequence[float] = (0.0, 0.3, 3.0),
) -> tuple[list[HypothesisScore], np.ndarray]:
    """Every hypothesis' log-likelihood gain (best over the random-walk steps ``walks``, in noise
    stds per window), best first, and the scales (H,); ``states`` (n, K, 8): the model's estimate.

    A walk of 0 holds delta constant, estimated from the data like a state: the simplest closed
    form.  A random walk can follow any delta(t), so every correction that moves the measured
    channels the same way (less alumina in the bath, say) scores alike with one; a constant delta
    tells them apart by how the correction acts over time (a feeder's gain acts per dose, a loss
    all the time), and where the hypothesis is right it scores best of all."""
    scales = hypothesis_scales(model, hypotheses, obs, window, states)
    n = obs.y.shape[0]
    pairs, result = _filter(model, hypotheses, scales=scales, obs=obs, window=window, walks=walks, backward=False)
    per_trajectory = result.log_likelihood.reshape(len(pairs), n)
    gains, rescued = likelihood_gains(per_trajectory[1:], per_trajectory[0])
    best: dict[int, HypothesisScore] = {}
    moving: dict[int, HypothesisScore] = {}  # the best step > 0 that holds
    for (j, walk), gain, held in zip(pairs[1:], gains, rescued, strict=True):
        score = HypothesisScore(
            hypothesis=hypotheses[j],
            scale=float(scales[j]),
            walk=walk,
            log_likelihood_gain=float(gain),
            rescued=int(held),
        )
        if j not in best or score.rank_key > best[j].rank_key:
            best[j] = score
        if walk > 0 and np.isfinite(gain) and (j not in moving or score.rank_key > moving[j].rank_key):
            moving[j] = score
    scores = [
        dataclasses.replace(score, smoothing_walk=moving[j].walk if j in moving else score.walk)
        for j, score in best.items()
    ]
    return best_first(scores), scales


def smooth_hypothesis(model: CellModel, score: HypothesisScore, obs: Observations, window: int) -> Smoothed:
    """Smoothed states and delta (in the hypothesis' own unit) of one hypothesis at its smoothing step."""
    walk = score.walk if score.smoothing_walk is None else score.smoothing_walk
    _, result = _filter(
        model, [score.hypothesis], scales=np.array([score.scale]), obs=obs, window=window, walks=[walk], backward=True
    )
    result.mean[..., 8] *= score.scale
    result.std[..., 8] *= score.scale
    return result


def mostly_lost(held: np.ndarray) -> bool:
    """Whether the filter is lost on half the trajectories or more (``held`` (n,) bool): what is
    estimated from the rest is too little to trust."""
    return 2 * int(np.sum(held)) <= len(held)


#: the passes of a one-term refinement at most (:func:`.search._one_term_if_better`), and its step, in
#: posterior spreads, below which it has converged: from a start at a seventh of a slope, a pass moves
#: a bounded step (-1 to -2.1 in two passes, -3.6 in eight, the truth -3.5)
MAX_PASSES, CONVERGED = 12, 0.1


class Refined(NamedTuple):
    """A closed form's coefficients refined on the measured channels (:func:`refine_coefficients`)."""

    coefficients: np.ndarray  # (P,)
    covariance: np.ndarray  # (P, P)


def refine_coefficients(
    model: CellModel,
    hypothesis: Hypothesis,
    features: Sequence[Feature],
    coefficients: np.ndarray,
    width: np.ndarray,
    obs: Observations,
    passes: int = 2,
    converged: float = 0.0,
) -> Refined | None:
    """Maximum-likelihood coefficients (P,) of a closed form and their covariance (P, P), on every
    trajectory of ``obs``.

    A regression on the smoothed delta(t) is attenuated where the random walk cannot follow
    delta (a tapping's step, a fast change): here the coefficients are constant states of the
    smoother, with a prior N(coefficients, width^2) and no process noise, so the measured
    channels themselves fit them.  Each trajectory's posterior is combined into one (the product
    of the trajectories' likelihoods; a trajectory whose filter is lost is left out), and each
    further pass re-linearises around the result, up to ``passes``, or until no coefficient moves by
    ``converged`` times its posterior spread.  None where the combined posterior is not a
    proper Gaussian (too nonlinear to trust) or half the trajectories or more are lost.
    """
    p = len(features)
    source = Parameters(p)
    kernel = CompiledModel(hypothesis.parametrised(model, features, source), obs.dt, obs.channels, [source])
    n = obs.y.shape[0]
    x0, cov0 = obs.prior()
    process = np.append(PROCESS_STD, np.zeros(p))
    theta = np.asarray(coefficients, dtype=float)
    for _ in range(passes):
        mean0 = np.column_stack([x0, np.tile(theta, (n, 1))])
        cov = np.zeros((8 + p, 8 + p))
        cov[:8, :8], cov[8:, 8:] = cov0, np.diag(width**2)
        result = kernel.smooth(
            obs.y, obs.u, mean0=mean0, cov0=cov, process_std=process, noise_std=obs.noise, backward=False
        )
        # in units of the prior widths, where the prior's precision is the identity (the
        # coefficients' own scales span many decades: a check in raw units tests rounding)
        means, covs = result.mean[:, -1, 8:] / width, result.final_cov[:, 8:, 8:] / np.outer(width, width)
        held = np.isfinite(means).all(1) & np.isfinite(covs).all((1, 2))
        if mostly_lost(held):
            return None
        means, covs, m = means[held], covs[held], int(held.sum())
        try:
            precisions = np.linalg.inv(covs)
        except np.linalg.LinAlgError:
            return None
        total = precisions.sum(0) - (m - 1) * np.eye(p)
        if np.any(np.linalg.eigvalsh(0.5 * (total + total.T)) <= 0):
            return None
        step = (
            width * np.linalg.solve(total, np.einsum("nij,nj->i", precisions, means) - (m - 1) * theta / width) - theta
        )
        theta, covariance = theta + step, np.linalg.inv(total) * np.outer(width, width)
        if np.all(np.abs(step) <= converged * np.sqrt(np.diag(covariance))):
            break
    return Refined(theta, covariance)
