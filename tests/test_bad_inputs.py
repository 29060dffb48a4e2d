"""A catalogue of bad inputs: each stops the README's smoke command in one line and changes no result.

Every entry is a config (merged over config/smoke.yaml), a measurement file for
discovery (named by ``discovery.user_data``) or an events file beside good measurements
(``discovery.user_data.events``) that must end the run with a non-zero
exit, one line naming the key, or the file, column and row, and every file under
``results/`` byte for byte as it was. The checks run when the workflow starts
(the Snakefile), so nothing is scheduled.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import SMOKE_COMMAND, file_hashes, run_command

# (name, config merged over the smoke config, what the one line must say)
CONFIGS = [
    ("unknown top-level key", "simulaton: {steps: 10}",
     "invalid config at '(top level)': Additional properties are not allowed ('simulaton' was unexpected)"),
    ("unknown nested key", "training: {epoch: 3}",
     "invalid config at 'training': Additional properties are not allowed ('epoch' was unexpected)"),
    ("text for an integer", "simulation: {steps: many}", "invalid config at 'simulation.steps': 'many' is not of type 'integer'"),
    ("text for a boolean", "training: {compile: maybe}", "invalid config at 'training.compile': 'maybe' is not of type 'boolean'"),
    ("float for an integer", "training: {instances: 2.5}", "invalid config at 'training.instances': 2.5 is not of type 'integer'"),
    ("negative time step", "simulation: {dt_s: -1}", "invalid config at 'simulation.dt_s': -1 is less than or equal to the minimum of 0"),
    ("no trajectories", "simulation: {train_trajectories: 0}",
     "invalid config at 'simulation.train_trajectories': 0 is less than the minimum of 1"),
    ("confidence above 1", "evaluation: {bootstrap: {confidence: 1.5}}",
     "invalid config at 'evaluation.bootstrap.confidence': 1.5 is greater than or equal to the maximum of 1"),
    ("negative seed", "seed: -1", "invalid config at 'seed': -1 is less than the minimum of 0"),
    ("unknown equations variant", "physics: {equations: latest}", "invalid config at 'physics.equations': 'latest' is not one of"),
    ("unknown constant", "physics: {overrides: {k99: 1.0}}", "invalid config at 'physics.overrides'"),
    ("range of three values", "simulation: {initial_conditions: {x1: [1, 2, 3]}}",
     "invalid config at 'simulation.initial_conditions.x1'"),
    ("empty hidden layers", "training: {hidden_layers: []}", "invalid config at 'training.hidden_layers'"),
    ("model type named pbm", "training: {model_types: {pbm: {target: ddm, l1_lambda: 0.0}}}",
     "invalid config at 'training.model_types'"),
    ("unknown training target", "training: {model_types: {ddm_dense: {target: gan, l1_lambda: 0.0}}}",
     "invalid config at 'training.model_types.ddm_dense.target': 'gan' is not one of ['ddm', 'costa']"),
    ("window beyond the trajectories", "evaluation: {windows: {long: [200, 900]}}",
     "evaluation.windows.long = [200, 900) does not fit trajectories of 400 steps (simulation.steps)"),
    ("reversed window", "evaluation: {windows: {medium: [200, 20]}}",
     "evaluation.windows.medium = [200, 20) does not fit trajectories of 400 steps (simulation.steps)"),
    ("overlapping windows", "evaluation: {windows: {medium: [10, 200]}}",
     "evaluation.windows.medium = [10, 200) overlaps evaluation.windows.short, which ends at 20; the windows must be disjoint"),
    ("horizon beyond the trajectories", "evaluation: {horizons: {long: 401}}",
     "evaluation.horizons.long = 401 does not fit trajectories of 400 steps (simulation.steps)"),
    ("saved trajectory that does not exist", "evaluation: {saved_trajectories: [0, 7]}",
     "evaluation.saved_trajectories [0, 7] must be below simulation.test_trajectories = 4"),
    ("figure trajectory not saved", "figures: {rolling_forecast_trajectory: 3}",
     "figures.rolling_forecast_trajectory = 3 must be one of evaluation.saved_trajectories [0, 1]"),
    ("figure of a model type that does not exist", "figures: {rolling_forecast_types: [ddm_huge]}",
     "figures.rolling_forecast_types ['ddm_huge'] are not in training.model_types"),
    ("discovery case that does not exist", "discovery: {cases: [paper_liquidus, no_such_effect]}",
     "invalid config at 'discovery.cases.1': 'no_such_effect' is not one of"),
    ("copied samples beyond the trajectories", "evaluation: {copied_samples: {networks: 400}}",
     "evaluation.copied_samples {'networks': 400, 'physics': 1} must be below simulation.steps = 400"),
    ("user data without a path", "discovery: {user_data: {name: cell}}", "invalid config at 'discovery.user_data'"),
    ("user data named like a shipped case", "discovery: {user_data: {path: cell.csv, name: paper_liquidus}}",
     "discovery.user_data.name 'paper_liquidus' is also a shipped case in discovery.cases; choose another name"),
    ("held-out fraction of 1", "discovery: {user_data: {path: cell.csv, held_out_fraction: 1.0}}",
     "invalid config at 'discovery.user_data.held_out_fraction': 1.0 is greater than or equal to the maximum of 1"),
]  # fmt: skip


def _drop_u3(t):
    return t.drop(columns="u3")


def _set(column, row, value):
    def edit(t):
        t = t.astype({column: object}) if isinstance(value, str) else t.copy()
        t.loc[row, column] = value
        return t

    return edit


def _time_backwards(t):
    t = t.copy()
    t.loc[5, "time_s"] = t.loc[3, "time_s"]
    return t


def _duplicated_step(t):
    return pd.concat([t.iloc[:7], t.iloc[6:]], ignore_index=True)


def _uneven_step(t):
    t = t.copy()
    t.loc[t.trajectory == 0, "time_s"] *= np.where(t.loc[t.trajectory == 0, "step"] < 200, 1.0, 1.5)
    return t


def _interleaved(t):
    return pd.concat([t[t.trajectory == 0].iloc[:100], t[t.trajectory == 1], t[t.trajectory == 0].iloc[100:],
                      t[t.trajectory == 2]], ignore_index=True)  # fmt: skip


def _one_short_trajectory(t):
    return t[t.trajectory == 0].iloc[:7]


def _pot_voltage_in_millivolts(t):
    t = t.assign(U_pot=4.2)
    t.loc[12, "U_pot"] = 4200.0
    return t


# (name, file name, how the good table is spoilt (or the file's text), what the one line must say)
DATA = [
    ("missing input column", "cell.csv", _drop_u3, "cell.csv: missing column(s) ['u3']"),
    ("unlogged input not declared", "cell.csv", lambda t: t.drop(columns="u5"),
     "cell.csv: missing column(s) ['u5'];"),
    ("NaN in an input", "cell.csv", _set("u2", 17, np.nan), "cell.csv: column 'u2' has no value at row 17 (the inputs u1..u5 are logged commands, needed at every step)"),
    ("inf in an input", "cell.csv", _set("u1", 250, np.inf), "cell.csv: column 'u1' has a non-finite value at row 250: inf"),
    ("NaN time", "cell.csv", _set("time_s", 9, np.nan), "cell.csv: column 'time_s' has no value at row 9 (a key)"),
    ("text in a numeric column", "cell.csv", _set("u5", 33, "high"), "cell.csv: column 'u5' is not numeric (row 33: 'high')"),
    ("time going backwards", "cell.csv", _time_backwards,
     "cell.csv: column 'time_s' must increase within a trajectory; row 5 goes from 40.0 to 30.0"),
    ("duplicated step", "cell.csv", _duplicated_step,
     "cell.csv: column 'time_s' must increase within a trajectory; row 7 goes from 60.0 to 60.0"),
    ("uneven time step", "cell.csv", _uneven_step, "cell.csv: column 'time_s' must have a uniform step"),
    ("trajectory rows not contiguous", "cell.csv", _interleaved,
     "cell.csv: rows of a trajectory must be contiguous (trajectory 0 reappears at row 500)"),
    ("negative mass", "cell.csv", _set("x2", 120, -5.0),
     "cell.csv: column 'x2' (Al2O3 mass) must be positive, row 120 has -5.0"),
    ("pot voltage in millivolts", "cell.csv", _pot_voltage_in_millivolts,
     "cell.csv: column 'U_pot' (pot voltage) must lie in 2.5-7 V where sampled, row 12 has 4200"),
    ("one trajectory too short to cut", "cell.csv", _one_short_trajectory,
     "cell.csv: one trajectory of 7 samples cannot be cut into 4 to learn from and hold out"),
    ("empty file", "cell.csv", "", "cell.csv: the file is empty"),
    ("header and no rows", "cell.csv", "trajectory,step,time_s,x1,x2,x3,x4,x5,x6,x7,x8,u1,u2,u3,u4,u5\n",
     "cell.csv: the table has columns but no rows"),
    ("semicolons for commas", "cell.csv", "semicolons", "cell.csv: the header 'trajectory;step;time_s;"),
    ("file that does not exist", "absent.csv", None, "absent.csv: no such file"),
    ("not a Parquet file", "cell.parquet", "trajectory,step\n0,0\n", "cell.parquet: cannot be read as parquet"),
    ("unknown format", "cell.xlsx", "PK\x03\x04", "cell.xlsx: unknown format '.xlsx'; use .parquet or .csv"),
]  # fmt: skip

# (name, the events table next to the good measurements (discovery.user_data.events), what the one line must say)
EVENTS = [
    ("event after the record", "trajectory,time_s,kind,amount_kg,duration_s\n0,3990,tap,1000,600\n",
     "events.csv: column 'time_s' at row 0: the tap from 3990 s to 4590 s lies outside trajectory 0 of"),
    ("events out of time order", "trajectory,time_s,kind,amount_kg\n0,600,alumina_dose,1.8\n0,300,alumina_dose,1.8\n",
     "events.csv: column 'time_s' must not decrease within a trajectory; row 1 goes back from 600 to 300"),
    ("unknown event kind", "trajectory,time_s,kind,amount_kg\n0,60,alumina_dose,1.8\n1,60,crust_break,900\n",
     "events.csv: column 'kind' has the unknown kind 'crust_break' at row 1; known: tap, alf3_addition, alumina_dose, anode_change"),
    ("a weighed dose", "trajectory,time_s,kind,amount_kg,weighed_kg\n0,60,alumina_dose,1.8,\n0,90,alumina_dose,1.8,1.7\n",
     "events.csv: column 'weighed_kg' has a value at row 1, a 'alumina_dose': only taps are weighed"),
]  # fmt: skip

# (name, the historian's files (historian: export, tags), what the one line must say); tests/test_historian.py has more
TAG_MAP = "signals: {POT.VOLT: {to: U_pot, unit: V}, LINE.AMPS: {to: u2, unit: kA}}\n"
HISTORIAN = [
    ("historian: an unknown tag", {"export.csv": "timestamp,tag,value\n2026-03-01 06:00:00,POT.VOLT,4.2\n"
                                                 "2026-03-01 06:00:05,POT.NOISE,1\n", "tags.yaml": TAG_MAP},
     "export.csv: tag 'POT.NOISE' at row 1 is not in the tag map"),
    ("historian: time going backwards", {"export.csv": "timestamp,tag,value\n2026-03-01 06:00:05,LINE.AMPS,140\n"
                                                       "2026-03-01 06:00:00,LINE.AMPS,140\n", "tags.yaml": TAG_MAP},
     "export.csv: tag 'LINE.AMPS' at row 1 goes back in time"),
    ("historian: a unit that does not convert", {"export.csv": "timestamp,tag,value\n", "tags.yaml": TAG_MAP.replace("kA", "kg")},
     "tags.yaml: signal 'LINE.AMPS' in kg does not convert to u2's unit A"),
]  # fmt: skip

CASES = [pytest.param(text, message, None, None, None, id=name) for name, text, message in CONFIGS]
CASES += [pytest.param(files, message, None, None, None, id=name) for name, files, message in HISTORIAN]
CASES += [pytest.param(None, message, file, spoil, None, id=name) for name, file, spoil, message in DATA]
CASES += [pytest.param(None, message, "cell.csv", lambda t: t, events, id=name) for name, events, message in EVENTS]


@pytest.fixture(scope="module")
def good_table(smoke_run) -> pd.DataFrame:
    """The smoke run's training set as a measurement table (3 trajectories x 400 steps)."""
    table = pd.read_parquet(smoke_run / "results/smoke/data/train.parquet")
    return table.drop(columns=["g1", "U_cell"])


def _write(folder, file, spoil, good_table) -> None:
    path = folder / file
    if spoil is None:
        return
    if callable(spoil):
        spoil(good_table).to_csv(path, index=False)
    elif spoil == "semicolons":
        good_table.to_csv(path, index=False, sep=";")
    else:
        path.write_text(spoil)


def _bad_config(folder: Path, config, file, spoil, events, good_table) -> Path:
    """The config file of one case, beside the measurement and events files it names."""
    folder.mkdir()
    if isinstance(config, dict):  # a historian's files
        for name, text in config.items():
            (folder / name).write_text(text)
        config = f"historian: {{export: {folder / 'export.csv'}, tags: {folder / 'tags.yaml'}}}"
    if file is not None:
        _write(folder, file, spoil, good_table)
        user = f"path: {folder / file}, name: cell"
        if events is not None:
            (folder / "events.csv").write_text(events)
            user += f", events: {folder / 'events.csv'}"
        config = f"discovery: {{user_data: {{{user}}}}}"
    bad = folder / "bad.yaml"
    bad.write_text(config + "\n")
    return bad


@pytest.fixture(scope="module")
def outcomes(smoke_run, good_table, tmp_path_factory) -> tuple[dict, dict, dict]:
    """Every case's run of the smoke command (side by side: each is one Python process that stops while
    reading its config), with the result files' hashes before and after all of them."""
    root = tmp_path_factory.mktemp("bad")
    configs = {case.id: _bad_config(root / str(i), *case.values[:1], *case.values[2:], good_table)
               for i, case in enumerate(CASES)}  # fmt: skip
    before = file_hashes(smoke_run / "results")
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 2) as pool:
        runs = dict(zip(configs, pool.map(lambda bad: run_command(smoke_run, f"{SMOKE_COMMAND} {bad}"),
                                          configs.values()), strict=True))  # fmt: skip
    return runs, before, file_hashes(smoke_run / "results")


@pytest.mark.parametrize(("config", "message", "file", "spoil", "events"), CASES)
def test_bad_input_stops_in_one_line_and_keeps_results(outcomes, request, config, message, file, spoil, events):
    runs, before, after = outcomes
    result = runs[request.node.callspec.id]
    assert result.returncode != 0
    lines = [line for line in (result.stdout + result.stderr).splitlines() if line.strip()]
    naming = [line for line in lines if message in line]
    assert len(naming) == 1 and naming[0] == lines[-1] and "Traceback" not in result.stderr, lines
    assert after == before, "a bad input's run changed a file under results/"
