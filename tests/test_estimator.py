"""The Kalman smoother against exact answers: on a linear Gaussian model it must equal conditioning
the joint Gaussian of all states and measurements directly.  The model is traced and compiled as
the cell model is (:class:`costa.compiled.CompiledSystem`)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from costa.compiled import CompiledSystem
from costa.compiled.trace import Row
from costa.discover.sparse.innovations import innovation_tests

PROCESS_STD, NOISE_STD = np.array([0.1, 0.2, 0.05]), np.array([0.3, 0.2])


def _matrices():
    a = np.array([[0.95, 0.1, 0.0], [0.0, 0.9, 0.05], [0.0, 0.0, 1.0]])  # the third state is a random walk
    b = np.array([[0.5], [0.0], [0.0]])
    h = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 1.0]])
    return a, b, h


def _times(matrix: np.ndarray, row: Row) -> list:
    """matrix @ row, written as the sums a traced row is computed with."""
    return [sum(m * row[j] for j, m in enumerate(line) if m) for line in matrix]


def _linear_system(a, b, h) -> CompiledSystem:
    """z' = A z + B u, y = H z, compiled."""

    def step(program, z, u):
        return Row([s + t for s, t in zip(_times(a, z), _times(b, u), strict=True)])

    def sensors(program, z, u):
        return Row(_times(h, z))

    return CompiledSystem({"step": step, "sensors": sensors}, states=3, inputs=1, channels=2)


def _exact(a, b, h, y, u, mean0, cov0):
    """Posterior means of all states and the log density of the measured values, by brute force."""
    steps, size = y.shape[0], a.shape[0]
    q, r = np.diag(PROCESS_STD**2), np.diag(NOISE_STD**2)
    # z_k = A^k z0 + sum_j A^(k-1-j) (B u_j + w_j): states as a linear map of (z0, w_0..w_{K-2})
    mean = np.zeros((steps, size))
    maps = np.zeros((steps, size, size * steps))
    mean[0], maps[0][:, :size] = mean0, np.eye(size)
    for k in range(1, steps):
        mean[k] = a @ mean[k - 1] + b @ u[k - 1]
        maps[k] = a @ maps[k - 1]
        maps[k][:, size * k : size * (k + 1)] = np.eye(size)
    sources = np.zeros((size * steps, size * steps))
    sources[:size, :size] = cov0
    for k in range(1, steps):
        sources[size * k : size * (k + 1), size * k : size * (k + 1)] = q
    z_cov = np.einsum("kip,pq,ljq->kilj", maps, sources, maps).reshape(steps * size, steps * size)
    big_h = np.kron(np.eye(steps), h)
    y_cov = big_h @ z_cov @ big_h.T + np.kron(np.eye(steps), r)
    measured = np.isfinite(y.ravel())
    y_mean = big_h @ mean.ravel()
    cross = z_cov @ big_h.T[:, measured]
    solve = np.linalg.solve(y_cov[np.ix_(measured, measured)], (y.ravel() - y_mean)[measured])
    posterior = mean.ravel() + cross @ solve
    posterior_cov = z_cov - cross @ np.linalg.solve(y_cov[np.ix_(measured, measured)], cross.T)
    log_density = multivariate_normal(y_mean[measured], y_cov[np.ix_(measured, measured)]).logpdf(y.ravel()[measured])
    return posterior.reshape(steps, size), np.sqrt(np.diag(posterior_cov)).reshape(steps, size), log_density


def test_smoother_equals_conditioning_the_joint_gaussian_with_missing_samples():
    rng = np.random.default_rng(7)
    a, b, h = _matrices()
    n, steps = 3, 12
    u = rng.normal(size=(n, steps, 1))
    y = rng.normal(size=(n, steps, 2))
    y[:, ::3, 0] = np.nan  # channel 0 missing every third step
    y[1, 4:9, :] = np.nan  # a gap in both channels
    y[2, :, 1] = np.nan  # a channel never measured in one trajectory
    mean0 = rng.normal(size=(n, 3))
    cov0 = np.diag([1.0, 2.0, 0.5])
    result = _linear_system(a, b, h).smooth(y, u, mean0, cov0, PROCESS_STD, NOISE_STD)
    for i in range(n):
        mean, std, log_density = _exact(a, b, h, y[i], u[i], mean0[i], cov0)
        np.testing.assert_allclose(result.mean[i], mean, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(result.std[i], std, rtol=1e-10, atol=1e-12)
        assert result.log_likelihood[i] == pytest.approx(log_density, rel=1e-12)
    assert np.isnan(result.innovation[2, :, 1]).all() and np.isfinite(result.innovation[0, 1:3]).all()


def test_innovations_of_the_true_model_pass_and_a_wrong_model_is_flagged():
    rng = np.random.default_rng(3)
    a, b, h = _matrices()
    n, steps = 20, 300
    u = rng.normal(size=(n, steps, 1))
    z = np.zeros((n, steps, 3))
    for k in range(1, steps):
        z[:, k] = z[:, k - 1] @ a.T + u[:, k - 1] @ b.T + rng.normal(size=(n, 3)) * PROCESS_STD
    y = z @ h.T + rng.normal(size=(n, steps, 2)) * NOISE_STD
    y[:, 1::2, 1] = np.nan  # the second channel every other step
    prior = (np.zeros((n, 3)), np.eye(3), PROCESS_STD, NOISE_STD)
    right = innovation_tests(_linear_system(a, b, h).smooth(y, u, *prior).innovation, ["first", "second"])
    assert not any(t.flagged for t in right)
    assert all(abs(t.chi2_per_dof - 1) < 0.1 for t in right)
    # the model misses the input's effect: the first channel's innovations follow u
    wrong = _linear_system(a, np.zeros_like(b), h).smooth(y, u, *prior)
    tests = {t.channel: t for t in innovation_tests(wrong.innovation, ["first", "second"])}
    assert tests["first"].flagged and tests["first"].chi2_per_dof > 1.5


def test_a_trajectory_whose_covariance_turns_singular_does_not_stop_the_others():
    """A state held without process noise that one trajectory's dynamics wipe out (its row of the
    transition's Jacobian is zero) leaves that trajectory a singular predicted covariance: the
    smoother returns it as NaN, and the other trajectories exactly as when run alone."""
    rng = np.random.default_rng(11)
    a, b, h = _matrices()

    def step(program, z, u):  # the second input, 0, resets the third state to zero; 1 keeps it
        moved = [s + t for s, t in zip(_times(a[:2, :2], z), _times(b[:2], u), strict=True)]
        return Row([*moved, u[1] * z[2]])

    def sensors(program, z, u):
        return Row(_times(h, z))

    system = CompiledSystem({"step": step, "sensors": sensors}, states=3, inputs=2, channels=2)
    n, steps = 3, 12
    u = np.concatenate([rng.normal(size=(n, steps, 1)), np.ones((n, steps, 1))], axis=-1)
    u[1, 5, 1] = 0.0
    y = rng.normal(size=(n, steps, 2))
    mean0, cov0 = rng.normal(size=(n, 3)), np.eye(3)
    noise = (np.array([0.1, 0.2, 0.0]), NOISE_STD)
    result = system.smooth(y, u, mean0, cov0, *noise)
    assert np.isnan(result.mean[1, :6]).all()
    alone = system.smooth(y[::2], u[::2], mean0[::2], cov0, *noise)
    np.testing.assert_allclose(result.mean[::2], alone.mean, rtol=1e-12)
    np.testing.assert_allclose(result.log_likelihood[::2], alone.log_likelihood, rtol=1e-12)


def test_a_trajectory_whose_innovation_covariance_is_not_positive_definite_is_lost_not_scored():
    """A covariance that is no longer one (here a negative prior variance; in a diverging filter, round-off)
    makes S = H P H' + R indefinite: the log density N(r; 0, S) is then undefined (r' S^-1 r can be
    hugely negative, a likelihood far above any real one), so the trajectory is lost (NaN) from there;
    the others are as when run alone."""
    rng = np.random.default_rng(5)
    a, b, h = _matrices()
    n, steps = 3, 8
    u, y, mean0 = rng.normal(size=(n, steps, 1)), rng.normal(size=(n, steps, 2)), rng.normal(size=(n, 3))
    cov0 = np.repeat(np.diag([1.0, 2.0, 0.5])[None], n, axis=0)
    cov0[1, 1, 1] = -4.0  # S's second diagonal: -4 + 0.5 + 0.2^2 < 0
    system = _linear_system(a, b, h)
    result = system.smooth(y, u, mean0, cov0, PROCESS_STD, NOISE_STD)
    assert np.isnan(result.log_likelihood[1]) and np.isnan(result.mean[1]).all()
    alone = system.smooth(y[::2], u[::2], mean0[::2], cov0[::2], PROCESS_STD, NOISE_STD)
    np.testing.assert_array_equal(result.log_likelihood[::2], alone.log_likelihood)
