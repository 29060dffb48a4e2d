"""States that nobody measured, estimated from partial, sparse and noisy measurements.

An extended Kalman filter and a Rauch-Tung-Striebel smoother, vectorised over
trajectories, for a discrete-time model

    z_{k+1} = transition(z_k, u_k) + w_k,   w_k ~ N(0, diag(process_std^2))
    y_k     = observe(z_k, u_k) + v_k,      v_k ~ N(0, diag(noise_std^2))

where any channel of y may be missing (NaN) at any step: a missing channel neither
updates the estimate nor counts in the likelihood.  Jacobians are forward finite
differences, taken for all trajectories and all directions in one batched call of
the model.  Augmenting z with random-walk states (a disturbance, a hypothesis'
delta(t)) turns the smoother into an estimator of unknown inputs; the marginal
likelihood of the data (from the innovations) compares such augmentations.

Returned innovations are standardised by their predicted std, channel by channel:
under a correct model they are white, zero-mean and of unit variance, which is
what :func:`innovation_tests` checks (the grey-box analogue of a residual test).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["ChannelTest", "Smoothed", "StateSpaceModel", "innovation_tests", "jacobian", "smooth"]

Batched = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class StateSpaceModel:
    """A discrete-time model with additive Gaussian noise (see the module docstring).

    ``transition`` and ``observe`` map states (B, L) and inputs (B, m) to (B, L) and
    (B, C); ``process_std`` is (L,), or (n, L) for a std per trajectory; ``scale`` (L,)
    is each state's typical magnitude (finite-difference steps are ``1e-6 * scale``).
    """

    transition: Batched
    observe: Batched
    process_std: np.ndarray
    noise_std: np.ndarray
    scale: np.ndarray


def jacobian(fn: Batched, z: np.ndarray, u: np.ndarray, step: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """fn(z, u) (B, O) and its Jacobian (B, O, L) by forward differences of ``step`` (L,)."""
    batch, size = z.shape
    points = np.repeat(z[:, None, :], size + 1, axis=1)
    points[:, 1:] += np.diag(step)
    inputs = np.repeat(u[:, None, :], size + 1, axis=1)
    values = fn(points.reshape(-1, size), inputs.reshape(batch * (size + 1), -1)).reshape(batch, size + 1, -1)
    return values[:, 0], np.swapaxes(values[:, 1:] - values[:, :1], 1, 2) / step


@dataclass
class Smoothed:
    """What the smoother found, per trajectory n and step k.

    ``mean``, ``std`` (n, K, L): smoothed states and their marginal std;
    ``innovation`` (n, K, C): standardised one-step-ahead prediction errors of the
    filter (NaN where the channel was not measured); ``log_likelihood`` (n,): the
    log density of each trajectory's measurements under the model; ``final_cov``
    (n, L, L): the covariance at the last step, given every measurement.
    """

    mean: np.ndarray
    std: np.ndarray
    innovation: np.ndarray
    log_likelihood: np.ndarray
    final_cov: np.ndarray


def _update(mean, cov, y, u, model: StateSpaceModel, step):
    """Measurement update at one step for the channels measured there (NaN: not measured)."""
    predicted, h = jacobian(model.observe, mean, u, step)
    measured = np.isfinite(y)
    residual = np.where(measured, y - predicted, 0.0)
    h = np.where(measured[..., None], h, 0.0)
    r = np.broadcast_to(model.noise_std**2, y.shape)
    s = h @ cov @ np.swapaxes(h, 1, 2) + r[..., None] * np.eye(y.shape[1])
    s = 0.5 * (s + np.swapaxes(s, 1, 2))
    gain = np.swapaxes(_solve(s, h @ cov), 1, 2)  # P H^T S^-1 (S symmetric)
    new_mean = mean + np.einsum("blc,bc->bl", gain, residual)
    joseph = np.eye(mean.shape[1]) - gain @ h
    new_cov = joseph @ cov @ np.swapaxes(joseph, 1, 2) + (gain * r[:, None, :]) @ np.swapaxes(gain, 1, 2)
    # log N(residual; 0, S) over the measured channels (an unmeasured one has S_cc = r_c, residual 0)
    sign, logdet = np.linalg.slogdet(s)
    logdet = logdet - np.where(measured, 0.0, np.log(r)).sum(-1)
    quadratic = np.einsum("bc,bc->b", residual, _solve(s, residual[..., None])[..., 0])
    log_likelihood = -0.5 * (quadratic + logdet + measured.sum(-1) * np.log(2 * np.pi))
    innovation = np.where(measured, residual / np.sqrt(np.diagonal(s, axis1=1, axis2=2)), np.nan)
    return new_mean, 0.5 * (new_cov + np.swapaxes(new_cov, 1, 2)), innovation, log_likelihood


def smooth(
    model: StateSpaceModel,
    y: np.ndarray,
    u: np.ndarray,
    mean0: np.ndarray,
    cov0: np.ndarray,
    backward: bool = True,
) -> Smoothed:
    """Filter forward, smooth backward.

    y (n, K, C) with NaN where not measured, u (n, K, m), the prior of the first
    state mean0 (n, L) and cov0 (n, L, L) or (L, L).  ``backward`` False: the filter
    only (innovations and likelihood; ``mean`` and ``std`` are then the filtered ones
    at the last step, (n, 1, L)), which keeps no history and fits many rows at once.
    """
    n, steps, _ = y.shape
    size = mean0.shape[-1]
    step = 1e-6 * model.scale
    q = np.broadcast_to(model.process_std**2, (n, size))[:, :, None] * np.eye(size)
    kept = steps if backward else 1
    means = np.empty((n, kept, size))
    covs = np.empty((n, kept, size, size))
    transitions = np.empty((n, kept - 1, size, size))
    predicted = np.empty((n, kept - 1, size))
    innovation = np.empty(y.shape)
    log_likelihood = np.zeros(n)
    mean, cov = mean0.astype(float), np.broadcast_to(cov0, (n, size, size)).astype(float)
    with np.errstate(all="ignore"):
        for k in range(steps):
            mean, cov, innovation[:, k], ll = _update(mean, cov, y[:, k], u[:, k], model, step)
            log_likelihood += ll
            slot = k if backward else 0
            means[:, slot], covs[:, slot] = mean, cov
            if k + 1 < steps:
                mean, a = jacobian(model.transition, mean, u[:, k], step)
                cov = a @ cov @ np.swapaxes(a, 1, 2) + q
                if backward:
                    transitions[:, k], predicted[:, k] = a, mean
        smoothed_mean, smoothed_cov = means.copy(), covs.copy()
        for k in range(kept - 2, -1, -1):
            a = transitions[:, k]
            predicted_cov = a @ covs[:, k] @ np.swapaxes(a, 1, 2) + q
            gain = np.swapaxes(_solve(predicted_cov, a @ covs[:, k]), 1, 2)  # P A^T Ppred^-1
            smoothed_mean[:, k] = means[:, k] + np.einsum("bij,bj->bi", gain, smoothed_mean[:, k + 1] - predicted[:, k])
            smoothed_cov[:, k] = covs[:, k] + gain @ (smoothed_cov[:, k + 1] - predicted_cov) @ np.swapaxes(gain, 1, 2)
    std = np.sqrt(np.clip(np.diagonal(smoothed_cov, axis1=2, axis2=3), 0.0, None))
    return Smoothed(smoothed_mean, std, innovation, log_likelihood, smoothed_cov[:, -1])


def _solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a^-1 b for a batch of matrices; a trajectory whose filter diverged (a singular or
    non-finite covariance) gets NaN instead of stopping the others."""
    try:
        return np.linalg.solve(a, b)
    except np.linalg.LinAlgError:
        out = np.full(np.broadcast_shapes(a.shape[:-1], b.shape[:-1]) + b.shape[-1:], np.nan)
        for i in range(len(a)):
            try:
                out[i] = np.linalg.solve(a[i], b[i])
            except np.linalg.LinAlgError:
                pass
        return out


@dataclass(frozen=True)
class ChannelTest:
    """Whether one measured channel's standardised innovations look like white unit noise.

    ``chi2_per_dof``: mean square (1 under a correct model); ``bias_z``: the mean in
    standard errors; ``whiteness_z``: the lag-1..``lags`` autocorrelation's Box-Pierce
    statistic as a z-score.  ``flagged``: any of the three beyond ``z_threshold``, and the
    excess material (chi-square above ``1 + min_excess`` or a mean beyond sqrt(min_excess)).
    """

    channel: str
    samples: int
    chi2_per_dof: float
    z: float
    bias: float
    bias_z: float
    whiteness_z: float
    flagged: bool


def _box_pierce_z(e: np.ndarray, lags: int) -> float:
    """Box-Pierce statistic of the (n, K) innovations with NaN gaps, pooled over trajectories, as a
    z-score of chi2: each lag's autocorrelation is weighted by its own number of pairs (its variance
    is 1/pairs under whiteness), so six samples a trajectory do not count as the pooled total."""
    statistic, used = 0.0, 0
    if np.isfinite(e).sum() <= lags + 1:
        return 0.0
    centred = e - np.nanmean(e)
    variance = np.nanmean(centred**2)
    for lag in range(1, lags + 1):
        products = centred[:, lag:] * centred[:, :-lag]
        pairs = np.isfinite(products).sum()
        if pairs:
            rho = np.nansum(products) / pairs / variance
            statistic, used = statistic + pairs * rho**2, used + 1
    return float((statistic - used) / np.sqrt(2 * used)) if used else 0.0


def innovation_tests(
    innovation: np.ndarray,
    channels: Sequence[str],
    z_threshold: float = 6.0,
    min_excess: float = 0.1,
    lags: int = 5,
) -> list[ChannelTest]:
    """Test each channel's standardised innovations (n, K, C): variance, bias and whiteness.

    Lags count measured samples of the channel, not steps: a channel sampled every
    hour is tested at lags of hours.
    """
    tests = []
    for c, name in enumerate(channels):
        e = innovation[..., c]
        present = np.isfinite(e)
        count = int(present.sum())
        if count == 0:
            continue
        packed = _packed(e)
        chi2 = float(np.nanmean(e**2))
        z = (chi2 - 1) / np.sqrt(2 / count)
        bias = float(np.nanmean(e))
        bias_z = bias * np.sqrt(count)
        white = _box_pierce_z(packed, lags)
        significant = max(z, abs(bias_z), white) > z_threshold
        material = chi2 - 1 > min_excess or bias**2 > min_excess
        tests.append(
            ChannelTest(name, count, chi2, float(z), bias, float(bias_z), white, bool(significant and material))
        )
    return tests


def _packed(e: np.ndarray) -> np.ndarray:
    """Each trajectory's measured values side by side (n, max count), NaN-padded: lags in samples."""
    rows = [row[np.isfinite(row)] for row in e.reshape(-1, e.shape[-1])]
    width = max(len(r) for r in rows)
    packed = np.full((len(rows), width), np.nan)
    for i, r in enumerate(rows):
        packed[i, : len(r)] = r
    return packed
