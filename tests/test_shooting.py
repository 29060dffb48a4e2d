"""Multiple shooting recovers a planted closed form from a pot line's sparse record."""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np
import pytest

from costa.discover.cases.tables import case_tables
from costa.discover.cases.unshipped import find_case
from costa.discover.core.hypotheses import candidate_hypotheses
from costa.discover.pipeline import starting_model
from costa.discover.sparse.pipeline import observations
from costa.discover.sparse.shooting.fit import Segments, damped_step, filtered_starts, shooting_fit
from costa.physics import model_from_config
from costa.sensors import declared_noise, sensor_sets_from_config
from costa.simulate import SimulationSettings, simulate_set


def _plant_record(default_config, case: str, hours: float, key: str):
    """The first 2 cells x ``hours`` of ``case``'s plant record, the full model and its hypothesis ``key``."""
    config = copy.deepcopy(default_config)
    config["discovery"]["sensor_sets"]["plant"].update(hours=hours, trajectories=2, held_out_trajectories=1)
    train, _ = case_tables(config, case, "plant")
    obs = observations(train, declared_noise(config["discovery"]["sensor_sets"], "plant"), case)
    model = starting_model(config, "full")
    return obs, model, next(h for h in candidate_hypotheses(model) if h.key == key)


@pytest.mark.integration
def test_a_planted_conductivity_law_is_recovered_from_a_short_plant_record(default_config):
    """The bath conductivity falls as exp(-3.5 (c3 - 0.11)) (shipped case conductivity_alf3); from
    2 cells x 24 h of the plant sensors (voltage every 10 s, bath temperature hourly, AlF3 and metal
    every 8 h), the uncorrected model's conductivity corrected by theta1 own (c3 - 0.11) +
    theta2 own (c3 - 0.11)^2 reaches the truth's expansion (-3.5, +6.125) from theta = 0, with
    starts read from the data alone, and every channel ends at its noise (about a minute)."""
    obs, model, hypothesis = _plant_record(default_config, "conductivity_alf3", 24, "part:bath_conductivity")
    terms = {f.name: f for f in hypothesis.features(rich=True)}
    fit = shooting_fit(model, hypothesis, [terms["own*(c3 - 0.11)"], terms["own*(c3 - 0.11)^2"]], obs)
    assert fit.lost == 0
    assert fit.theta[0] == pytest.approx(-3.5, abs=0.2) and fit.theta[1] == pytest.approx(6.125, abs=1.0)
    assert all(0.5 < chi2 < 1.5 for chi2 in fit.chi2.values()), fit.chi2


@pytest.mark.integration
def test_a_missing_heat_loss_is_fitted_through_the_continuity_stages(default_config):
    """top_heat_loss takes 22 W/K (x6 - 35 degC) from the bath: -20 570 W - 22 W/K (x6 - 970) as the
    bath energy's missing flow.  From 2 cells x 12 h of the plant sensors and theta = 0, the fit
    through the continuity stages (100, 10, 3, 1 x the filter's process noise) comes within 3 % of the
    constant with every channel at its noise (about a minute).  Fitted at the filter's continuity
    alone it stopped at -6 620 W: the segments are tied too tightly to leave the data's placement."""
    obs, model, hypothesis = _plant_record(default_config, "top_heat_loss", 12, "term:bath_energy")
    terms = {f.name: f for f in hypothesis.features()}
    staged = shooting_fit(model, hypothesis, [terms["1"], terms["(x6 - 970)"]], obs)
    assert staged.theta[0] == pytest.approx(-20570.0, rel=0.03) and staged.at_noise, (staged.theta, staged.chi2)


def test_eliminating_each_cells_states_solves_the_whole_normal_equations():
    """The Schur-complement step equals the damped Gauss-Newton step of the whole system
    [[A_1 .. 0 B_1], [.. ..], [0 .. A_n B_n], [B_1^T .. B_n^T C]] solved at once."""
    rng = np.random.default_rng(0)
    n, size, terms = 3, 16, 2
    jacobian = rng.normal(size=(n, 40, size))
    coupling = rng.normal(size=(n, 40, terms))
    residual = rng.normal(size=(n, 40))
    a = np.einsum("nki,nkj->nij", jacobian, jacobian)
    b = np.einsum("nki,nkp->nip", jacobian, coupling)
    c = np.einsum("nkp,nkq->pq", coupling, coupling)
    g = np.einsum("nki,nk->ni", jacobian, residual)
    h = np.einsum("nkp,nk->p", coupling, residual)
    whole = np.zeros((n * size + terms, n * size + terms))
    for i in range(n):
        cell = slice(i * size, (i + 1) * size)
        whole[cell, cell], whole[cell, n * size :], whole[n * size :, cell] = a[i], b[i], b[i].T
    whole[n * size :, n * size :] = c
    damping = 0.1
    damped = whole + damping * np.diag(np.diag(whole))
    expected = np.linalg.solve(damped, -np.concatenate([g.reshape(-1), h]))
    step_states, step_theta = damped_step(a, b, g, c, h, damping)
    np.testing.assert_allclose(np.concatenate([step_states, step_theta]), expected, rtol=1e-9, atol=1e-12)


def test_the_filter_places_the_bath_mass_that_no_sensor_reads(default_config):
    """The plant sensors read no bath mass; the data's placement assumes the nominal 14 t, and the
    second cell of top_heat_loss's record holds 17-18 t.  The true model's smoothed states put each
    hourly segment's bath mass, after the first hour, within 1 t of the simulated truth (within 0.3 t
    on that cell), and its ledge within 0.6 t."""
    config = copy.deepcopy(default_config)
    config["discovery"]["sensor_sets"]["plant"].update(hours=6, trajectories=2, held_out_trajectories=1)
    train, _ = case_tables(config, "top_heat_loss", "plant")
    obs = observations(train, declared_noise(config["discovery"]["sensor_sets"], "plant"), "top_heat_loss")
    true, _ = find_case("top_heat_loss").models(model_from_config(config["physics"])[0])
    starts = filtered_starts(true, obs)[:, 1:]
    plant = sensor_sets_from_config(config["discovery"]["sensor_sets"])["plant"]
    settings = SimulationSettings.from_config(config["simulation"])
    settings = replace(settings, steps=plant.steps(settings.dt, settings.steps), operation=plant.operation)
    simulated, _ = simulate_set(true, settings, 2, config["seed"], 0, "discovery/top_heat_loss/train")
    truth = simulated.x[:, :: round(3600 / obs.dt)][:, 1 : starts.shape[1] + 1]
    bath, bath_true = starts[..., 1:4].sum(-1), truth[..., 1:4].sum(-1)
    assert (abs(bath_true[1] - 14000.0) > 2500).all()
    assert abs(bath - bath_true).max() < 1000 and abs(bath[1] - bath_true[1]).max() < 300
    assert abs(starts[..., 0] - truth[..., 0]).max() < 600


def test_each_segments_path_from_the_true_hourly_states_retraces_the_simulation(default_config):
    """A segment integrated from the simulated state at its first step, under the model and inputs
    that made the record, passes through every simulated state of its hour (to rounding): the path
    the shooting route hands to what-to-measure-next is the model's own trajectory."""
    config = copy.deepcopy(default_config)
    config["discovery"]["sensor_sets"]["plant"].update(hours=3, trajectories=2, held_out_trajectories=1)
    train, _ = case_tables(config, "top_heat_loss", "plant")
    obs = observations(train, declared_noise(config["discovery"]["sensor_sets"], "plant"), "top_heat_loss")
    true, _ = find_case("top_heat_loss").models(model_from_config(config["physics"])[0])
    plant = sensor_sets_from_config(config["discovery"]["sensor_sets"])["plant"]
    settings = SimulationSettings.from_config(config["simulation"])
    settings = replace(settings, steps=plant.steps(settings.dt, settings.steps), operation=plant.operation)
    simulated, _ = simulate_set(true, settings, 2, config["seed"], 0, "discovery/top_heat_loss/train")
    segments = Segments(true, None, [], obs, round(3600 / obs.dt))
    x = simulated.x[:, : segments.count * segments.steps]
    path = segments.path(x[:, :: segments.steps].reshape(-1, 8), np.zeros(0))
    error = np.abs(path - x).max(axis=(0, 1)) / np.abs(x).max(axis=(0, 1))
    assert (error < 1e-9).all(), error
