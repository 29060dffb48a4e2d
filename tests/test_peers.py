"""The peers (PySINDy, the UDE recipe) recover a known missing term; the table; the DAG."""

from __future__ import annotations

import copy
import re
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest
from conftest import REPOSITORY

from costa.discover import CASES, add_noise
from costa.discover.cases.tables import case_tables
from costa.discover.cases.truth import TRUTHS, changed_equations, correction_variables, term_variables
from costa.discover.cases.unshipped import UNSHIPPED, find_case
from costa.discover.findings import findings
from costa.discover.pipeline import run_discovery, starting_model
from costa.discover.reference import train_costa
from costa.metrics import EvaluationSettings, state_scale
from costa.peers.compare import METHODS, compare_case
from costa.peers.methods import PeerSettings, pysindy_peer, ude_peer
from costa.peers.score import COLUMNS, DASH
from costa.peers.sparse import FEATURES, SparseFit, corrected_per_row
from costa.physics import BalanceTerm, operating_points
from costa.simulate import simulate_set

#: a bath heat loss of 300 W/K (x6 - 970) + 10 kW: exactly two terms of the flow library
LOSS = {"1": -10000.0, "(x6 - 970)": -300.0}


@pytest.fixture(scope="module")
def heat_loss_data(model, settings):
    """The full model with a hidden bath heat loss, 6 trajectories x 1500 steps, 0.2 % noise."""
    loss = BalanceTerm("loss", "1e4 + 300 (x6 - 970)", "W", {"bath_energy": -1.0},
                       lambda v, k, q: 1e4 + 300.0 * (v.x6 - 970.0))  # fmt: skip
    true = model.with_terms(loss)
    data, _ = simulate_set(true, replace(settings, steps=1500), 6, seed=5, replicate=0, stream_name="test/peers")
    x = add_noise(data.x, 0.002, np.random.default_rng(7))
    return x, data.u, settings.dt


@pytest.fixture(scope="module")
def evaluation():
    windows = {"short": (0, 100), "medium": (100, 750), "long": (750, 1500)}
    return EvaluationSettings(windows, {"short": 100, "medium": 750, "long": 1500})


SMALL = PeerSettings(thresholds=(0.1, 0.3), windows=(41,), ensemble=20, stride=5, seed=3)


def _bath_energy_terms(result) -> dict[str, float]:
    return {t["term"]: t["value"] for t in result.fit.terms().get("x6", [])}


@pytest.mark.integration  # a minute each: the whole peer fit on a case
def test_pysindy_recovers_a_missing_flow(model, heat_loss_data, evaluation):
    x, u, dt = heat_loss_data
    result = pysindy_peer(model, x, u, dt, state_scale(x), evaluation, SMALL)
    found = _bath_energy_terms(result)
    assert set(found) == set(LOSS), (result.grid, result.fit.terms())
    for term, value in LOSS.items():
        assert found[term] == pytest.approx(value, rel=0.1), found
    assert result.grid["chosen"].sum() == 1 and set(result.grid.columns) >= {"window", "threshold", "terms"}


@pytest.mark.integration  # a minute each: the whole peer fit on a case
def test_ude_recovers_a_missing_flow(model, heat_loss_data, evaluation, default_config):
    x, u, dt = heat_loss_data
    config = copy.deepcopy(default_config)
    config["discovery"]["costa_reference"] = {"instances": 2, "epochs": 20}
    result = ude_peer(
        lambda data: train_costa(config, data, model, "test"), model, x, u, dt, state_scale(x), evaluation, SMALL
    )
    found = _bath_energy_terms(result)
    assert found.get("1") == pytest.approx(LOSS["1"], rel=0.2), result.fit.terms()


def test_a_grid_of_fits_rolls_out_as_each_fit_alone(model, heat_loss_data):
    """The batched validation: block g of the stacked model is fit g's own corrected model."""
    x, u, dt = heat_loss_data
    rng = np.random.default_rng(0)
    fits = []
    for kept in (3, 0, 5):  # a fit with no term leaves its block on the starting model
        coefficients = np.zeros((8, len(FEATURES)))
        for i, j in zip(rng.integers(0, 8, kept), rng.choice(len(FEATURES), kept, replace=False), strict=True):
            coefficients[i, j] = rng.normal() * 1e-3
        fits.append(SparseFit(coefficients, coefficients != 0))
    states, inputs = x[:2, ::50], u[:2, ::50]
    stacked = corrected_per_row(model, fits, 2, "grid").rhs(np.tile(states, (3, 1, 1)), np.tile(inputs, (3, 1, 1)))
    for g, fit in enumerate(fits):
        alone = fit.corrected(model, "one").rhs(states, inputs)
        np.testing.assert_allclose(stacked[2 * g : 2 * g + 2], alone, rtol=1e-12)
    assert fits[1].corrected(model, "none") is model


def test_truths_are_facts_about_the_models(model, rng):
    x, u = operating_points(rng, 200)
    for name, equations in (("printed_k4", ("x3",)), ("top_heat_loss", ("x6",)), ("wall_conductivity", ("x7", "x8"))):
        true, start = find_case(name).models(model)
        assert changed_equations(true, start, x, u) == equations, name
    # -22 (x6 - 35) W in the library's centred terms
    assert TRUTHS["top_heat_loss"].coefficients["term:bath_energy"] == {"1": -22 * (970 - 35), "(x6 - 970)": -22}
    assert term_variables("u1*superheat") == {"u1", "superheat"} and term_variables("own*(c3 - 0.11)") == {"c3"}
    assert correction_variables("input:u1", "1") == {"u1"}  # a feeder's gain reads the feed
    assert correction_variables("term:alumina_mass", "u1*superheat") == {"u1", "superheat"}
    assert set(CASES) | set(UNSHIPPED) <= set(TRUTHS)


def test_the_table_has_every_column_and_method(smoke_config):
    config = copy.deepcopy(smoke_config)
    config["peers"].update(thresholds=[0.3], smoothing_windows=[21], ensemble=2, stride=4)
    case = find_case("top_heat_loss")
    train, held_out = case_tables(config, case)
    start = starting_model(config, case.starting)
    found = findings(run_discovery(config, train, held_out, start, case.name, case.name), case.name, start, {})
    rows, details = compare_case(config, case.name, train, held_out, found)
    assert list(rows.columns) == COLUMNS and tuple(rows["method"]) == METHODS
    assert (rows.loc[rows["method"] != "this workflow", "named"] == DASH).all()
    assert rows["true_equations"].eq("x6").all() and (rows["rollouts"] == 2).all()
    assert {"PySINDy", "UDE (CoSTA + PySINDy)", "true_equations"} <= set(details)


def test_an_unknown_peers_case_is_named():
    from costa.config import ConfigError, load_config

    with pytest.raises(ConfigError, match="peers.cases: unknown discovery case 'hidden_dragon'"):
        load_config(overrides={"peers": {"cases": ["hidden_dragon"]}})


def test_the_peers_dag_on_the_smoke_config(tmp_path):
    result = subprocess.run(
        [sys.executable, "-m", "snakemake", "results/smoke/peers/summary.csv", "--snakefile", str(REPOSITORY / "Snakefile"),
         "--directory", str(tmp_path), "-n", "--quiet", "rules", "--configfile", str(REPOSITORY / "config" / "smoke.yaml")],
        capture_output=True, text=True, cwd=tmp_path,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr[-3000:]
    jobs = {m[1]: int(m[2]) for m in re.finditer(r"^(\w+)\s+(\d+)$", result.stdout, re.MULTILINE)}
    # the smoke config's two peer cases: one shipped, one unshipped, each simulated and discovered
    assert jobs.get("peers_case") == 2 and jobs.get("discover") == 2 and jobs.get("collect_peers") == 1, result.stdout
