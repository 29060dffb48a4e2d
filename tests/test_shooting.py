"""Multiple shooting recovers a planted closed form from a pot line's sparse record."""

from __future__ import annotations

import copy

import pytest

from costa.discover.cases.tables import case_tables
from costa.discover.core.hypotheses import candidate_hypotheses
from costa.discover.pipeline import starting_model
from costa.discover.sparse.pipeline import observations
from costa.discover.sparse.shooting import shooting_fit
from costa.sensors import declared_noise


@pytest.mark.integration
def test_a_planted_conductivity_law_is_recovered_from_a_short_plant_record(default_config):
    """The bath conductivity falls as exp(-3.5 (c3 - 0.11)) (shipped case conductivity_alf3); from
    2 cells x 24 h of the plant sensors (voltage every 10 s, bath temperature hourly, AlF3 and metal
    every 8 h), the uncorrected model's conductivity corrected by theta1 own (c3 - 0.11) +
    theta2 own (c3 - 0.11)^2 reaches the truth's expansion (-3.5, +6.125) from theta = 0, with
    starts read from the data alone, and every channel ends at its noise (about 30 s)."""
    config = copy.deepcopy(default_config)
    config["discovery"]["sensor_sets"]["plant"].update(hours=24, trajectories=2, held_out_trajectories=1)
    train, _ = case_tables(config, "conductivity_alf3", "plant")
    obs = observations(train, declared_noise(config["discovery"]["sensor_sets"], "plant"), "conductivity_alf3")
    model = starting_model(config, "full")
    hypothesis = next(h for h in candidate_hypotheses(model) if h.key == "part:bath_conductivity")
    terms = {f.name: f for f in hypothesis.features(rich=True)}
    fit = shooting_fit(model, hypothesis, [terms["own*(c3 - 0.11)"], terms["own*(c3 - 0.11)^2"]], obs)
    assert fit.lost == 0
    assert fit.theta[0] == pytest.approx(-3.5, abs=0.2) and fit.theta[1] == pytest.approx(6.125, abs=1.0)
    assert all(0.5 < chi2 < 1.5 for chi2 in fit.chi2.values()), fit.chi2
