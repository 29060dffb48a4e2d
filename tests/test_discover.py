"""Discovery: its building blocks against facts, bad data, and every shipped hidden-effect case."""

from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np
import pytest

from costa.data import TrajectoryDataError, to_table
from costa.discover import CASES, DiscoverySettings, HiddenEffectCase, add_noise, discover
from costa.discover.cases.tables import case_tables
from costa.discover.cases.truth import TRUTHS
from costa.discover.cases.unshipped import UNSHIPPED
from costa.discover.core.hypotheses import candidate_hypotheses
from costa.discover.core.naming import naming_order, removal
from costa.discover.core.noise import estimate_noise
from costa.discover.core.regression import (
    GramSystem,
    coefficient_samples,
    resample_weights,
    selection_frequency,
    stepwise,
)  # fmt: skip
from costa.discover.findings import findings, findings_markdown
from costa.discover.full_state.search import Candidate
from costa.discover.full_state.weak_form import WeakForm, equation_tests
from costa.discover.pipeline import run_discovery, split_held_out, starting_model
from costa.physics import PART_ORDER, InputCorrection, ablated_model, operating_points
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


def test_a_channel_that_reads_a_rippling_input_has_its_noise_estimated_net_of_the_ripple(rng):
    """A pot voltage read as 4.2 V + 17 µΩ × a line current of 140 kA ± 0.3 % white ripple, plus a
    slow drift and a 5 mV sensor (the pot line's slope and sensor): the ripple moves the voltage by
    7 mV a step, so the plain estimate is 1.7 times the sensor's 5 mV; net of the current's second
    differences it is the sensor's. Inputs that never move (u1, u3..u5 here) change nothing."""
    steps, cells = 4000, 3
    current = 140e3 * (1.0 + 0.003 * rng.standard_normal((cells, steps)))
    drift = 0.05 * np.sin(np.linspace(0.0, 3.0, steps))
    voltage = 4.2 + 17e-6 * current + drift + 0.005 * rng.standard_normal((cells, steps))
    inputs = np.zeros((cells, steps, 5))
    inputs[..., 1] = current
    inputs[..., 4] = 0.05
    plain = estimate_noise(voltage[..., None])[0]
    net = estimate_noise(voltage[..., None], inputs)[0]
    assert plain > 1.5 * 0.005
    assert net == pytest.approx(0.005, rel=0.03)
    still = inputs.copy()
    still[..., 1] = 140e3
    assert estimate_noise(voltage[..., None], still)[0] == plain


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


def test_a_correction_that_makes_the_disagreement_worse_reads_as_such():
    """The share removed is 1 - excess after / excess before: -200 % is an excess three times as large."""
    assert removal(0.99) == "removes 99% of the excess"
    assert removal(-2.0, "the flagged channels' excess") == "adds 200% to the flagged channels' excess"


def test_sensitivities_match_the_analytic_derivatives(model, rng):
    x, u = operating_points(rng, 50)
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
    x, u = operating_points(rng, 20)
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


def test_an_input_correction_is_the_delivered_input_everywhere(model, rng):
    x, u = operating_points(rng, 20)
    feeder = model.with_input(InputCorrection("u1", "-0.08", lambda v: -0.08))
    delivered = u.copy()
    delivered[:, 0] *= 0.92
    np.testing.assert_array_equal(feeder.rhs(x, u), model.rhs(x, delivered))
    assert "u1 delivered = u1 x (1 - 0.08)" in feeder.describe()
    # the gain's sensitivity: d(dx/dt)/d(gain) = u1 (1, -k4, k5) in the Al2O3, AlF3 and cryolite balances
    gain = next(h for h in candidate_hypotheses(model) if h.key == "input:u1").sensitivity(model, x, u)
    k = model.params
    np.testing.assert_allclose(gain[:, 1:4], u[:, :1] * [1.0, -k.k4, k.k5], rtol=1e-6, atol=1e-12)
    np.testing.assert_array_equal(gain[:, [0, 4, 5, 6, 7]], 0)


def test_each_part_reads_what_its_formula_names(model, rng):
    reads = model.reads(*operating_points(rng, 1))
    assert {"bath_conductivity", "bubble_voltage", "u2", "u5"} <= reads["cell_voltage"]
    assert {"liquidus_temperature", "k1", "k2", "x7"} <= reads["freezing_rate"]
    assert "bath_conductivity" not in reads["bubble_thickness"]


def _candidate(model, key: str, terms: int) -> Candidate:
    h = next(h for h in candidate_hypotheses(model) if h.key == key)
    return Candidate(hypothesis=h, features=h.features()[:terms], coefficients=np.ones(terms))


def test_the_cause_is_named_before_its_consequences(model, rng):
    reads = model.reads(*operating_points(rng, 1))
    order = lambda keys, named=(): [c.hypothesis.key for c in naming_order(  # noqa: E731
        [_candidate(model, k, n) for k, n in keys], named, reads, terms=lambda c: len(c.features))]  # fmt: skip
    # U and P_el are computed from g2: g2 is named, though its closed form has more terms
    voltage = [("part:cell_voltage", 1), ("part:electric_power", 1), ("part:bath_conductivity", 2)]
    assert order(voltage)[0] == "part:bath_conductivity"
    # among parts none of which is computed from another, and flows: fewest terms, a flow first
    assert order([("part:bath_ledge_heat", 1), ("term:bath_energy", 1), ("part:electric_power", 1)]) == [
        "term:bath_energy", "part:electric_power", "part:bath_ledge_heat"]  # fmt: skip
    # a logged input that enters one balance, and a flow proportional to it there: the input
    assert order([("term:metal_mass", 1), ("part:metal_production", 1), ("input:u4", 1)])[0] == "input:u4"
    # an input is upstream of the parts that read it; a property of the parts reading its constants
    assert order([("part:cell_voltage", 1), ("input:u5", 2)])[0] == "input:u5"
    assert order([("part:freezing_rate", 1), ("property:ledge_conductivity", 2)])[0] == "property:ledge_conductivity"
    # an effect named in an earlier round is refined first
    assert order(voltage, named=("part:electric_power",))[0] == "part:electric_power"
    assert PART_ORDER.index("bath_conductivity") < PART_ORDER.index("cell_voltage")


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
    weights = resample_weights(40, 100, rng)
    inclusion, samples = selection_frequency(system, weights), coefficient_samples(system, [7, 9], weights)
    assert inclusion[7] == 1.0 and inclusion[9] > 0.9 and inclusion[[0, 1, 3, 4, 5]].max() < 0.3
    assert np.quantile(samples[:, 0], 0.025) < -1.5 < np.quantile(samples[:, 0], 0.975)


@pytest.mark.parametrize(
    ("corrupt", "message"),
    [
        (lambda t: t[t.step < 100], "trajectories of 100 samples are too short; discovery needs at least 257"),
    ],
)
def test_unsuitable_data_get_one_clear_error(clean, default_config, corrupt, message):
    table = corrupt(to_table(clean.x, clean.u, 10.0))
    with pytest.raises(TrajectoryDataError, match=message):
        run_discovery(default_config, table, table, starting_model(default_config, "full"), "t", "measurements.csv")


def test_one_trajectory_is_cut_by_time_the_last_piece_held_out(clean, tmp_path):
    """One pot's record: learned on its first pieces, held out on the last; the split in words; a record
    too short to cut, or a fraction that holds out everything, is refused naming the file."""
    path = tmp_path / "one.csv"
    one = to_table(clean.x[:1], clean.u[:1], 10.0)
    one.iloc[:1001].to_csv(path, index=False)
    train, held_out, how = split_held_out(path, 0.34)  # 3 pieces of 333 samples, the first 2 left out
    assert train.trajectory.unique().tolist() == [0, 1] and held_out.trajectory.unique().tolist() == [2]
    assert (train.groupby("trajectory").size() == 333).all() and len(held_out) == 333
    assert held_out.time_s.iloc[-1] == one.time_s.iloc[1000] and train.time_s.iloc[0] == one.time_s.iloc[2]
    assert (held_out.step.to_numpy() == np.arange(333)).all()
    assert np.array_equal(np.r_[train.x6.to_numpy(), held_out.x6.to_numpy()], one.x6.to_numpy()[2:1001])
    assert how == (
        "one trajectory cut by time into 3 of 333 samples (0.925 h, its first 2 samples left out): "
        "2 learned from, the last 1 held out"
    )
    one.iloc[:3].to_csv(path, index=False)
    with pytest.raises(TrajectoryDataError, match="one.csv: one trajectory of 3 samples cannot be cut into 4"):
        split_held_out(path, 0.25)
    to_table(clean.x[:2], clean.u[:2], 10.0).to_csv(path, index=False)
    with pytest.raises(TrajectoryDataError, match=r"one.csv: held_out_fraction 0.8 of 2 trajectories holds out every"):
        split_held_out(path, 0.8)
    to_table(clean.x, clean.u, 10.0).to_csv(path, index=False)
    train, held_out, how = split_held_out(path, 0.25)
    assert sorted(held_out.trajectory.unique()) == [4, 5] and train.trajectory.nunique() == 4
    assert how == "6 trajectories: 4 learned from, the last 2 held out"


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
    assert {"closed_form", "coefficients", "other_terms_inclusion", "chi2_after", "kept_if"} <= set(named)
    nested = [c["ci99"][0] <= c["ci95"][0] <= c["value"] <= c["ci95"][1] <= c["ci99"][1] for c in named["coefficients"]]
    assert all(nested), named["coefficients"]
    text = findings_markdown(found)
    assert "## Round 1" in text and "Gap shrink" in text and "part:liquidus_temperature" in text
    assert "99 % interval" in text and "A term is kept if" in text


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


#: shipped cases whose truth a rival of other physics fits as well on every state at the reduced size
#: (at the full size the truth is named): the feeder's shortfall also feeds 8 % less AlF3 and cryolite,
#: 2-3 % of the feed, below those balances' noise, so an alumina flow proportional to the feed fits
#: alike; the truth is applied, the rival listed
NOT_IDENTIFIABLE_REDUCED = {"alumina_feeder": "term:alumina_mass"}


def _check(found, case: HiddenEffectCase, rival: str | None = None):
    """``rival``: the case is not identifiable, the truth applied and ``rival`` listed."""
    assert set(found["flagged_equations"]) == set(case.expected_equations), found["rounds"][0]["equations"]
    if not case.accepted:
        assert found["outcome"] == "no effect" and not found["named"]
        return
    if rival is not None:
        first = found["rounds"][0]
        assert found["outcome"] == "not identifiable" and not found["named"], found["named"]
        assert first["correction"]["hypothesis"] in case.accepted, first["correction"]["hypothesis"]
        assert rival in {c["hypothesis"] for c in first["equivalent"]}
    else:
        assert found["named"] and found["named"][0] in case.accepted, found["named"]
    assert found["gap"]["shrink_above_noise_floor"]["long"] >= 0.8, found["gap"]
    # what is kept agrees with what is reported: no kept term's interval covers zero
    kept = [c for r in found["rounds"] if r["correction"] for c in r["correction"]["coefficients"]]
    assert all(c["ci99"][0] > 0 or c["ci99"][1] < 0 for c in kept), kept
    assert all(c["ci99"][0] <= c["ci95"][0] <= c["value"] <= c["ci95"][1] <= c["ci99"][1] for c in kept), kept


#: the first round's closed form where the hidden effect is one the library can write exactly
KNOWN = {
    "wall_conductivity": {"(x8 - 580)": 0.004},
    "alumina_dissolution": {"u1": -0.3, "u1*superheat": 0.015},
    "alumina_feeder": {"1": -0.08},
    "tapping_shortfall": {"1": -0.1},
}


# the paper's case and the null case run by default; the other seven in the integration tier
@pytest.mark.parametrize(
    "case",
    [c if c in ("paper_liquidus", "no_effect") else pytest.param(c, marks=pytest.mark.integration) for c in CASES],
)
def test_shipped_case_at_reduced_size(default_config, case):
    found = _run(_config(default_config, REDUCED), case)
    _check(found, CASES[case], NOT_IDENTIFIABLE_REDUCED.get(case))
    if case in KNOWN:  # exactly the true terms are kept, each within 5 % of its value
        coefficients = {c["term"]: c["value"] for c in found["rounds"][0]["correction"]["coefficients"]}
        assert coefficients.keys() == KNOWN[case].keys(), coefficients
        assert all(abs(coefficients[t] - v) <= 0.05 * abs(v) for t, v in KNOWN[case].items()), coefficients


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CASES))
def test_shipped_case_at_full_size(default_config, case):
    found = _run(copy.deepcopy(default_config), case)
    _check(found, CASES[case])
    assert found["discovery_seconds"] < 120


#: effects the workflow was not designed around (:mod:`costa.discover.cases.unshipped`), with the closed
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
