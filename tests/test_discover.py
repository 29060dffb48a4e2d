"""Discovery: its building blocks against facts, bad data, and every shipped hidden-effect case."""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np
import pytest
from conftest import random_operating_points

from costa.data import TrajectoryDataError, to_table
from costa.discover import CASES, DiscoverySettings, HiddenEffectCase, add_noise, discover
from costa.discover.findings import findings, findings_markdown
from costa.discover.hypotheses import candidate_hypotheses
from costa.discover.pipeline import case_tables, run_discovery, split_held_out, starting_model
from costa.discover.regression import GramSystem, bootstrap, stepwise
from costa.discover.truth import TRUTHS
from costa.discover.unshipped import UNSHIPPED
from costa.discover.weak_form import WeakForm, equation_tests, estimate_noise
from costa.physics import ablated_model
from costa.simulate import simulate_set


@pytest.fixture(scope="module")
def clean(model, settings):
    """Noise-free trajectories of the full model: 6 x 1200 steps."""
    return simulate_set(model, replace(settings, steps=1200), 6, seed=3, replicate=0, stream_name="test/discovery")[0]


def test_one_rk4_step_of_the_true_model_leaves_no_residual(clean, model):
    residual = WeakForm(64, 10.0).residual(model, clean.x, clean.u)
    assert np.abs(residual).max() < 1e-9


def test_noise_estimate_from_second_differences(clean, rng):
    noisy = add_noise(clean.x, 0.01, rng)
    true_std = 0.01 * clean.x.reshape(-1, 8).std(0)
    np.testing.assert_allclose(estimate_noise(noisy), true_std, rtol=0.05)


def test_no_equation_is_flagged_on_noisy_data_from_the_model_itself(clean, model, rng):
    noisy = add_noise(clean.x, 0.01, rng)
    form = WeakForm(64, 10.0)
    scale = form.noise_scale(model, noisy, clean.u, estimate_noise(noisy), rng)
    tests = equation_tests(form.residual(model, noisy, clean.u), scale)
    assert not any(t.flagged for t in tests)
    assert all(0.6 < t.chi2_per_dof < 1.3 for t in tests), [t.chi2_per_dof for t in tests]


def test_a_disagreement_no_hypothesis_can_explain_is_reported_not_invented(clean, model, rng):
    ablated = ablated_model(model)
    settings = DiscoverySettings(min_screen=1e9, max_rounds=1, seed=1)  # no hypothesis passes the screen
    rounds, _ = discover(ablated, add_noise(clean.x, 0.01, rng), clean.u, 10.0, settings)
    assert rounds[0].flagged and rounds[0].chosen is None
    assert "no hypothesis could remove" in rounds[0].verdict and rounds[0].window == 64


def test_sensitivities_match_the_analytic_derivatives(model, rng):
    x, u = random_operating_points(rng, 50)
    hypotheses = {h.key: h for h in candidate_hypotheses(model)}
    k = model.params
    liquidus = hypotheses["part:liquidus_temperature"].sensitivity(model, x, u)
    np.testing.assert_allclose(liquidus[:, 0], k.k1 / (k.k0 * x[:, 0]) + k.k2, rtol=1e-4)  # d(dx1/dt)/dg1
    np.testing.assert_allclose(liquidus[:, 3], -liquidus[:, 0], rtol=1e-9)
    np.testing.assert_array_equal(liquidus[:, [1, 2, 4, 7]], 0)
    bath = hypotheses["term:bath_energy"].sensitivity(model, x, u)
    np.testing.assert_allclose(bath[:, 5], k.alpha / x[:, 1:4].sum(1))
    transfer = hypotheses["transfer:ledge_energy->wall_energy"].sensitivity(model, x, u)
    np.testing.assert_allclose(transfer[:, 6], -k.beta / x[:, 0])
    np.testing.assert_allclose(transfer[:, 7], k.k17)


def test_a_part_cannot_be_corrected_by_what_is_computed_from_it(model):
    liquidus = next(h for h in candidate_hypotheses(model) if h.key == "part:liquidus_temperature")
    names = [f.name for f in liquidus.features()]
    assert "(c2 - 0.03)" in names and not any("superheat" in n for n in names)
    flow = next(h for h in candidate_hypotheses(model) if h.key == "term:alumina_mass")
    assert "u1*superheat" in [f.name for f in flow.features()]


def test_corrected_models_add_the_closed_form(model, rng):
    x, u = random_operating_points(rng, 20)
    hypotheses = {h.key: h for h in candidate_hypotheses(model)}
    term = hypotheses["term:bath_energy"]
    features = [f for f in term.features() if f.name in ("1", "(x6 - 970)")]
    corrected = term.corrected(model, features, [-2e4, -22.0])
    expected = model.rhs(x, u)[:, 5] + model.params.alpha / x[:, 1:4].sum(1) * (-2e4 - 22.0 * (x[:, 5] - 970))
    np.testing.assert_allclose(corrected.rhs(x, u)[:, 5], expected, rtol=1e-12)
    assert "-2e+04 - 22*(x6 - 970)" in corrected.describe()
    part = hypotheses["part:bath_conductivity"]
    relative = [f for f in part.features() if f.name == "own*(c3 - 0.11)"]
    g2 = part.corrected(model, relative, [-3.5])
    q0, q1 = model.quantities(x, u), g2.quantities(x, u)
    c3 = x[:, 2] / x[:, 1:4].sum(1)
    np.testing.assert_allclose(q1["bath_conductivity"], q0["bath_conductivity"] * (1 - 3.5 * (c3 - 0.11)), rtol=1e-12)
    assert "g2*(c3 - 0.11)" in g2.parts["bath_conductivity"].formula


def test_stepwise_finds_a_sparse_support_and_skips_duplicates(rng):
    n = 4000
    design = rng.normal(size=(n, 12))
    design[:, 11] = 3 * design[:, 2]  # an exact duplicate of term 2
    target = 2.0 * design[:, 2] - 1.5 * design[:, 7] + 0.3 * design[:, 9] + rng.normal(size=n)
    groups = np.repeat(np.arange(40), n // 40)
    system = GramSystem.from_design(design, target, groups)
    fit = stepwise(*system.total(), max_terms=6)
    assert sorted(fit.selected) in ([2, 7, 9], [7, 9, 11])
    coefficients = dict(zip(fit.selected, fit.coefficients, strict=True))
    assert coefficients.get(7) == pytest.approx(-1.5, abs=0.05)
    inclusion, samples = bootstrap(system, [7, 9], 100, rng)
    assert inclusion[7] == 1.0 and inclusion[9] > 0.9 and inclusion[[0, 1, 3, 4, 5]].max() < 0.3
    assert np.quantile(samples[:, 0], 0.025) < -1.5 < np.quantile(samples[:, 0], 0.975)


@pytest.mark.parametrize(
    ("corrupt", "message"),
    [
        (lambda t: t[t.step < 100], "trajectories of 100 samples are too short; discovery needs at least 257"),
        (lambda t: t.assign(u5=0.05), r"inputs \['u5'\] do not vary"),
    ],
)
def test_unsuitable_data_get_one_clear_error(clean, default_config, corrupt, message):
    table = corrupt(to_table(clean.x, clean.u, 10.0))
    with pytest.raises(TrajectoryDataError, match=message):
        run_discovery(default_config, table, table, starting_model(default_config, "full"), "t", "measurements.csv")


def test_a_single_trajectory_cannot_be_split(clean, tmp_path):
    path = tmp_path / "one.csv"
    to_table(clean.x[:1], clean.u[:1], 10.0).to_csv(path, index=False)
    with pytest.raises(TrajectoryDataError, match="needs at least 2 trajectories"):
        split_held_out(path, 0.25)
    to_table(clean.x, clean.u, 10.0).to_csv(path, index=False)
    train, held_out = split_held_out(path, 0.25)
    assert sorted(held_out.trajectory.unique()) == [4, 5] and train.trajectory.nunique() == 4


def _run(config: dict, case: str | HiddenEffectCase):
    case = CASES[case] if isinstance(case, str) else case
    train, held_out = case_tables(config, case)
    start = starting_model(config, case.starting)
    result = run_discovery(config, train, held_out, start, case.name, case.name)
    meta = {"data": "test", "hidden": case.hidden, "kind": case.kind,
            "expected_equations": list(case.expected_equations), "accepted": list(case.accepted)}  # fmt: skip
    return findings(result, case.name, start, meta)


def test_findings_are_complete_and_readable(smoke_config):
    config = copy.deepcopy(smoke_config)
    found = _run(config, "paper_liquidus")
    assert found["outcome"] == "found" and found["named"][0] == "part:liquidus_temperature"
    named = found["rounds"][0]["named"]
    assert {"closed_form", "coefficients", "other_terms_inclusion", "chi2_after"} <= set(named)
    assert all(c["ci95"][0] <= c["value"] <= c["ci95"][1] for c in named["coefficients"])
    text = findings_markdown(found)
    assert "## Round 1" in text and "Gap shrink" in text and "part:liquidus_temperature" in text


#: every shipped case at a reduced size that keeps the suite fast; the full size is the slow test
REDUCED = {
    "discovery": {"trajectories": 16, "held_out_trajectories": 8},
    "simulation": {"steps": 3000},
    "evaluation": {"windows": {"short": [0, 100], "medium": [100, 1500], "long": [1500, 3000]},
                   "horizons": {"short": 100, "medium": 1500, "long": 3000}},
}  # fmt: skip


def _config(default_config, overrides):
    config = copy.deepcopy(default_config)
    for section, values in overrides.items():
        config[section].update(values)
    return config


def _check(found, case: HiddenEffectCase):
    assert set(found["flagged_equations"]) == set(case.expected_equations), found["rounds"][0]["equations"]
    if not case.accepted:
        assert found["outcome"] == "no effect" and not found["named"]
        return
    assert found["named"] and found["named"][0] in case.accepted, found["named"]
    assert found["gap"]["shrink_above_noise_floor"]["long"] >= 0.8, found["gap"]


@pytest.mark.parametrize("case", list(CASES))
def test_shipped_case_at_reduced_size(default_config, case):
    _check(_run(_config(default_config, REDUCED), case), CASES[case])


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CASES))
def test_shipped_case_at_full_size(default_config, case):
    found = _run(copy.deepcopy(default_config), case)
    _check(found, CASES[case])
    assert found["discovery_seconds"] < 120


#: effects the workflow was not designed around (:mod:`costa.discover.unshipped`), with the closed
#: form that is true: the workflow must generalise beyond the shipped cases.  These effects are small
#: (the starting model is within about 2x of the noise floor), so the test asks for the right name and
#: coefficients rather than a share of a gap that is itself mostly noise.
@pytest.mark.slow
@pytest.mark.parametrize("name", list(UNSHIPPED))
def test_effects_that_are_not_shipped_cases(default_config, name):
    case = UNSHIPPED[name]
    found = _run(copy.deepcopy(default_config), case)
    assert set(found["flagged_equations"]) == set(case.expected_equations), found["rounds"][0]["equations"]
    first = found["rounds"][0]["named"]
    assert first is not None and first["hypothesis"] in case.accepted, found["rounds"][0]["verdict"]
    truth = TRUTHS[name].coefficients[first["hypothesis"]]
    coefficients = {c["term"]: c["value"] for c in first["coefficients"]}
    assert coefficients.keys() == truth.keys()
    assert all(abs(coefficients[t] - v) <= 0.1 * abs(v) for t, v in truth.items()), coefficients
    assert found["gap"]["shrink"]["long"] > 0.2, found["gap"]


def test_bad_discovery_config_is_named():
    from costa.config import ConfigError, load_config

    with pytest.raises(ConfigError, match="discovery.user_data"):
        load_config(overrides={"discovery": {"user_data": {"file": "x.csv"}}})
    with pytest.raises(ConfigError, match="also a shipped case"):
        load_config(overrides={"discovery": {"user_data": {"path": "x.csv", "name": "no_effect"}}})
    with pytest.raises(ConfigError, match="discovery.cases"):
        load_config(overrides={"discovery": {"cases": ["hidden_dragon"]}})
