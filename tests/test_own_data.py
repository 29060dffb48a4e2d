"""Your own data and your own cell: data of any length, the gap's windows, the worked example."""

from __future__ import annotations

import copy
import importlib.util
import json

import numpy as np
import pandas as pd
import pytest
from conftest import REPOSITORY

from costa.config import load_config
from costa.data import TrajectoryDataError, load_trajectories
from costa.discover.findings import findings, findings_markdown
from costa.discover.pipeline import gap_settings, run_discovery, split_held_out, starting_model

EXAMPLE = REPOSITORY / "examples" / "own-cell"


@pytest.fixture(scope="module")
def example_config() -> dict:
    return load_config(REPOSITORY / "config" / "config.yaml", EXAMPLE / "config.yaml")


def _user(config: dict, **user) -> dict:
    config = copy.deepcopy(config)
    config["discovery"]["user_data"] = {**config["discovery"]["user_data"], **user}
    return config


def test_the_gap_windows_of_your_data_are_fractions_of_its_length(example_config):
    """The paper's proportions at any length; the paper's windows at 5000 steps; the evaluation section unused."""
    assert example_config["evaluation"]["windows"]["long"] == [2500, 5000]  # the paper's, untouched
    assert dict(gap_settings(example_config, "cell", 400).windows) == {
        "short": (0, 8), "medium": (8, 200), "long": (200, 400),
    }  # fmt: skip
    paper = gap_settings(example_config, "cell", 5000)
    assert dict(paper.windows) == {"short": (0, 100), "medium": (100, 2500), "long": (2500, 5000)}
    assert dict(paper.horizons) == {"short": 100, "medium": 2500, "long": 5000}
    own = _user(example_config, gap_windows={"short": [0, 0.1], "medium": [0.1, 0.6], "long": [0.6, 1.0]})
    assert dict(gap_settings(own, "cell", 400).windows) == {"short": (0, 40), "medium": (40, 240), "long": (240, 400)}


def test_a_shipped_case_keeps_the_evaluation_windows(smoke_config):
    assert dict(gap_settings(smoke_config, "paper_liquidus", 400).windows) == {
        "short": (0, 20), "medium": (20, 200), "long": (200, 400),
    }  # fmt: skip


def test_a_gap_window_empty_at_this_length_is_named(example_config):
    with pytest.raises(TrajectoryDataError, match=r"user_data.gap_windows: window 'short' = \[0, 0.02\) of 20 steps"):
        gap_settings(example_config, "cell", 20)


def test_bad_gap_windows_in_the_config_are_named():
    from costa.config import ConfigError

    user = {"path": "x.csv", "gap_windows": {"short": [0, 0.1], "medium": [0.5, 0.2], "long": [0.5, 1]}}
    with pytest.raises(ConfigError, match=r"gap_windows.medium = \[0.5, 0.2\)"):
        load_config(overrides={"discovery": {"user_data": user}})
    with pytest.raises(ConfigError, match="gap_windows"):
        load_config(overrides={"discovery": {"user_data": {"path": "x.csv", "gap_windows": {"long": [0, 1]}}}})


def test_a_sparse_table_takes_the_estimator_route_and_needs_its_sensors_noise(example_config, tmp_path):
    """x2 absent and x7 sampled every 30 steps: discovery goes through the state estimator, which
    asks for the noise of the channel too sparse to estimate it, naming the channel and the key."""
    table = pd.read_csv(EXAMPLE / "cell.csv")
    table["x7"] = table.x7.where(np.arange(len(table)) % 30 == 0)
    path = tmp_path / "sparse.csv"
    table.drop(columns=["x2"]).to_csv(path, index=False)
    train, held_out, _ = split_held_out(path, 0.34)  # splitting works on any table of the contract
    with pytest.raises(
        TrajectoryDataError,
        match=r"sparse.csv: channel 'x7' is not sampled at every step, so its noise cannot be estimated from the "
        r"data; declare it in discovery.user_data.noise",
    ):
        run_discovery(example_config, train, held_out, starting_model(example_config, "full"), "cell", str(path))


def _pot_voltage_log(example_config, path, spoil=None):
    """The example cell as a pot line logs it: the inputs and the pot voltage U_pot at every step."""
    from costa.data import arrays
    from costa.observe import observe

    table = pd.read_csv(EXAMPLE / "cell.csv")
    x, u = arrays(table)
    logged = table[["trajectory", "time_s", "u1", "u2", "u3", "u4", "u5"]].copy()
    logged["U_pot"] = observe(starting_model(example_config, "full"), x, u, ["U_pot"]).ravel()
    (spoil or (lambda t: t))(logged).to_csv(path, index=False)
    return path


def test_a_pot_voltage_log_is_a_channel(example_config, tmp_path):
    from costa.data import channel_report, measured_trajectories

    table = load_trajectories(_pot_voltage_log(example_config, tmp_path / "pot.csv"))
    report = channel_report(table).set_index("channel")
    assert report.loc["U_pot", ["status", "unit", "interval_s"]].tolist() == ["every step", "V", 10.0]
    measured = measured_trajectories(table)
    assert measured.channels == ("U_pot",) and 3.8 < np.median(measured.channel("U_pot")) < 4.6


def test_a_pot_voltage_out_of_the_plausible_range_is_named(example_config, tmp_path):
    """A sample logged in mV instead of V: one error with the file, the column and the row."""

    def in_millivolts(table):
        table.loc[37, "U_pot"] *= 1000
        return table

    path = _pot_voltage_log(example_config, tmp_path / "pot.csv", in_millivolts)
    with pytest.raises(TrajectoryDataError) as error:
        load_trajectories(path)
    assert str(error.value).startswith(
        f"{path}: column 'U_pot' (pot voltage) must lie in 2.5-7 V where sampled, row 37 has 4"
    )


def test_the_worked_example_finds_the_heat_loss_of_400_step_data(example_config):
    """6 x 400 steps of another cell with a heat loss through the top the model lacks (make_data.py)."""
    user = example_config["discovery"]["user_data"]
    train, held_out, _ = split_held_out(REPOSITORY / user["path"], user["held_out_fraction"])
    assert train.trajectory.nunique() == 4 and held_out.trajectory.nunique() == 2
    start = starting_model(example_config, "full")
    assert start.params.k9 == 21.5 and start.params.k16 == 30.0  # the example's cell
    result = run_discovery(example_config, train, held_out, start, "cell", user["path"])
    found = findings(result, "cell", start, {"data": "x"})
    # without the voltage, a thinner bubble layer's Joule heat fits the bath's equation within the margin:
    # nothing is named, the best fit (the truth) is applied, and the rival is listed
    first = found["rounds"][0]
    assert found["flagged_equations"] == ["x6"] and found["outcome"] == "not identifiable" and not found["named"]
    assert first["correction"]["hypothesis"] == "term:bath_energy"
    assert "part:bubble_thickness" in {c["hypothesis"] for c in first["equivalent"]}
    coefficient = first["correction"]["coefficients"][0]["value"]
    assert -22.0 * (990 - 30) < coefficient < -22.0 * (950 - 30)  # the true loss at bath temperatures 950-990 degC
    assert found["gap"]["windows"] == {"short": [0, 8], "medium": [8, 200], "long": [200, 400]}
    assert found["gap"]["shrink_above_noise_floor"]["long"] > 0.8
    assert "short [0, 8) = 0-80 s" in findings_markdown(found)


def test_a_record_with_constant_line_current_and_no_tap_names_what_it_can(example_config, tmp_path):
    """A pot line holds the current and taps once a day: 6 x 400 steps of the worked example's
    cell and heat loss with u2 at 140 kA and no tap (u4 = 0) go through, the heat
    loss is named, and the findings say what the record cannot decide."""
    from costa import seeds
    from costa.data import to_table
    from costa.discover import CASES, add_noise
    from costa.physics import model_from_config
    from costa.simulate import SimulationSettings, simulate_set

    config = load_config(
        REPOSITORY / "config" / "config.yaml", REPOSITORY / "config" / "smoke.yaml", EXAMPLE / "config.yaml"
    )
    simulation = copy.deepcopy(config["simulation"])
    simulation["excitation"]["line_current"]["offset"] = [0.0, 0.0]
    simulation["excitation"]["anode_cathode_distance"]["offset"] = [0.0, 0.0]
    simulation["controllers"]["metal_tapping"].update(min_rate=0.0, max_rate=0.0)
    settings = SimulationSettings.from_config(simulation)
    true, _ = CASES["top_heat_loss"].models(model_from_config(config["physics"])[0])
    simulated, _ = simulate_set(true, settings, 6, config["seed"], 0, "constant-inputs")
    assert np.ptp(simulated.u[..., 1]) == 0 and np.ptp(simulated.u[..., 3]) == 0
    noisy = add_noise(simulated.x, 0.01, seeds.numpy_generator(config["seed"], 0, "constant-inputs/noise"))
    path = tmp_path / "cell.csv"
    table = to_table(noisy, simulated.u, settings.dt).drop(columns=["step", "u5"])  # the line logs no u5
    table.to_csv(path, index=False, float_format="%.6g")
    with pytest.raises(TrajectoryDataError, match=r"missing column\(s\) \['u5'\].*unlogged_inputs with the value"):
        split_held_out(path, 1 / 3)
    train, held_out, _ = split_held_out(path, 1 / 3, {"u5": 0.05})
    assert (train["u5"] == 0.05).all()
    start = starting_model(example_config, "full")
    meta = {"data": "x", "unlogged_inputs": {"u5": 0.05}}
    found = findings(run_discovery(example_config, train, held_out, start, "cell", str(path)), "cell", start, meta)
    assert found["named"][0] == "term:bath_energy"
    assert [i["input"] for i in found["inputs_that_did_not_vary"]] == ["u2", "u4", "u5"]
    assert "line current did not vary" in found["inputs_that_did_not_vary"][0]["consequence"]
    assert "not logged: held at the declared 0.05 m" in found["inputs_that_did_not_vary"][2]["consequence"]
    assert "**Inputs that did not vary**" in findings_markdown(found)
    named_terms = [c["term"] for c in found["rounds"][0]["named"]["coefficients"]]
    assert not any(u in t for t in named_terms for u in ("u2", "u4", "u5"))


def test_the_example_data_are_what_the_documented_script_makes(tmp_path):
    spec = importlib.util.spec_from_file_location("make_data", EXAMPLE / "make_data.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.main(tmp_path / "cell.csv")
    assert (tmp_path / "cell.csv").read_bytes() == (EXAMPLE / "cell.csv").read_bytes()
    assert load_trajectories(tmp_path / "cell.csv").shape == (6 * 400, 16)


@pytest.mark.integration
def test_the_worked_example_runs_from_the_readme_command(tmp_path):
    """`snakemake --cores 2 results/own-cell/discovery/cell/findings.json --configfile examples/own-cell/config.yaml`."""
    from test_workflow import snakemake

    (tmp_path / "examples" / "own-cell").mkdir(parents=True)
    (tmp_path / "examples" / "own-cell" / "cell.csv").write_bytes((EXAMPLE / "cell.csv").read_bytes())
    targets = ["results/own-cell/discovery/cell/findings.json", "results/own-cell/cell_constants.csv"]
    snakemake(tmp_path, *targets, "--configfile", str(EXAMPLE / "config.yaml"))
    found = json.loads((tmp_path / targets[0]).read_text())
    assert found["outcome"] == "not identifiable" and found["gap"]["windows"]["long"] == [200, 400]
    assert found["rounds"][0]["correction"]["hypothesis"] == "term:bath_energy"  # applied: the truth
    assert {c["channel"]: c["status"] for c in found["channels"]}["x6"] == "every step"
    assert {c["constant"]: c["value"] for c in found["constants"]}["k9"] == 21.5
    markdown = (tmp_path / "results/own-cell/discovery/cell/findings.md").read_text()
    assert "docs/glossary.md" in markdown and "x6 (bath temperature, degC): 2400 samples" in markdown
    assert "**How often a name is right**" in markdown and "on the benchmark's full records" in markdown
    constants = pd.read_csv(tmp_path / targets[1]).set_index("constant")
    assert constants.loc["k16", "value"] == 30.0 and constants.loc["k14", "value"] == 0.12 / (2 * 8.0)
    assert not (tmp_path / "results" / "discovery").exists()  # under the example's own results folder
