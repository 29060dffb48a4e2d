"""Candidate closed forms scored in one batch: the same numbers as one at a time, and a grid that finds a planted form."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from costa.config import load_config
from costa.discover.core.hypotheses import candidate_hypotheses
from costa.discover.sparse.batched import closed_form_likelihoods
from costa.discover.sparse.observations import Observations
from costa.discover.sparse.observed import estimate_states
from costa.physics import true_model
from costa.simulate import SimulationSettings, simulate_set

TRUTH = (-0.003, -4e-5)  # AlF3 lost at 0.003 kg/s, less by 4e-5 kg/s per kelvin of bath above 970 degC


@pytest.fixture(scope="module")
def planted():
    """Four 2-hour records of a cell losing AlF3 as TRUTH: the AlF3 fraction and the bath temperature every 10 s."""
    model = true_model()
    (term,) = [h for h in candidate_hypotheses(model) if h.key == "term:alf3_mass"]
    features = [f for f in term.features(False) if f.name in ("1", "(x6 - 970)")]
    truth = term.corrected(model, features, list(TRUTH))
    settings = SimulationSettings.from_config(load_config()["simulation"])
    trajectories, _ = simulate_set(truth, replace(settings, steps=720), 4, 5, 0, "batched")
    x = trajectories.x
    c3 = x[..., 2:3] / x[..., 1:4].sum(-1, keepdims=True)
    noise = np.array([1e-4, 0.2])
    y = np.concatenate([c3, x[..., 5:6]], axis=-1) + np.random.default_rng(2).normal(0, noise, x.shape[:2] + (2,))
    return model, term, features, Observations(y, trajectories.u, ("c3", "x6"), noise, 10.0)


def test_the_batched_scores_equal_one_at_a_time(planted):
    """Five coefficient rows in one batch give each row's per-cell log-likelihood as its own filter
    does, to rounding; a row whose model cannot be evaluated on a cell reads -inf there."""
    model, term, features, obs = planted
    rows = np.array([[0.0, 0.0], [-0.003, -4e-5], [-0.002, 0.0], [0.001, 1e-4], [-0.004, -1e-4]])
    batched = closed_form_likelihoods(model, term, features, rows, obs)
    alone = np.stack(
        [
            estimate_states(term.corrected(model, features, list(r)), obs.y, obs.u, obs.channels, obs.noise, obs.dt,
                            backward=False).log_likelihood
            for r in rows
        ]
    )  # fmt: skip
    assert batched.shape == (5, 4)
    np.testing.assert_allclose(batched, alone, rtol=1e-9)
    broken = Observations(obs.y, obs.u.copy(), obs.channels, obs.noise, obs.dt)
    broken.u[1, 50, 1] = np.nan  # no line current logged on cell 1
    lost = closed_form_likelihoods(model, term, features, rows[:2], broken)
    assert np.all(lost[:, 1] == -np.inf) and np.all(np.isfinite(lost[:, [0, 2, 3]]))


def test_a_grid_of_closed_forms_finds_a_planted_one_in_seconds(planted):
    """A 9 x 9 grid of the two coefficients in physical units (81 candidates x 4 cells, one batch)
    peaks at the planted form: within one grid step of each coefficient."""
    model, term, features, obs = planted
    constants, slopes = np.linspace(-0.006, 0.002, 9), np.linspace(-1.2e-4, 4e-5, 9)
    grid = np.array([(a, b) for a in constants for b in slopes])
    total = closed_form_likelihoods(model, term, features, grid, obs).sum(1)
    best = grid[np.argmax(total)]
    assert abs(best[0] - TRUTH[0]) <= 1e-3 + 1e-12 and abs(best[1] - TRUTH[1]) <= 2e-5 + 1e-12
