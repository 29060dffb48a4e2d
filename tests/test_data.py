"""The trajectory table: round trip, units, and one clear error per kind of bad input."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from costa.data import (
    TrajectoryDataError,
    arrays,
    channel_report,
    load_trajectories,
    measured_trajectories,
    to_table,
    write_trajectories,
)


@pytest.fixture()
def table(rng) -> pd.DataFrame:
    x = rng.uniform(100, 1000, (3, 20, 8))
    u = rng.uniform(0, 1, (3, 20, 5))
    return to_table(x, u, 10.0, {"g1": rng.uniform(960, 970, (3, 20)), "U_cell": rng.uniform(4, 5, (3, 20))})


def test_round_trip_keeps_values_units_and_provenance(table, tmp_path):
    path = tmp_path / "t.parquet"
    write_trajectories(table, path, {"seed": 3})
    loaded = load_trajectories(path)
    pd.testing.assert_frame_equal(loaded, table)
    schema = pq.read_schema(path)
    assert schema.field("x6").metadata[b"unit"] == b"degC"
    assert schema.field("u2").metadata[b"unit"] == b"A"
    assert json.loads(schema.metadata[b"costa.provenance"]) == {"seed": 3}
    x, u = arrays(loaded)
    assert x.shape == (3, 20, 8) and u.shape == (3, 20, 5)
    np.testing.assert_array_equal(x[1, :, 5], table.loc[table.trajectory == 1, "x6"])


def test_csv_without_step_column_is_accepted(table, tmp_path):
    path = tmp_path / "measured.csv"
    table.drop(columns=["step", "g1", "U_cell"]).to_csv(path, index=False)
    loaded = load_trajectories(path)
    np.testing.assert_array_equal(loaded["step"], table["step"])


def _write(table: pd.DataFrame, tmp_path, name="bad.csv"):
    path = tmp_path / name
    table.to_csv(path, index=False)
    return path


@pytest.mark.parametrize(
    ("corrupt", "message"),
    [
        (
            lambda t: t.assign(x6=t.x6.where(t.index != 7, np.inf)),
            r"bad\.csv: column 'x6' has a non-finite value at row 7",
        ),
        (
            lambda t: t.assign(u3=t.u3.where(t.index != 6, np.nan)),
            r"bad\.csv: column 'u3' has no value at row 6 \(the inputs u1..u5 are logged commands",
        ),
        (lambda t: t.drop(columns=["u5"]), r"bad\.csv: missing column\(s\) \['u5'\]"),
        (
            lambda t: t.drop(columns=["x1", "x2", "x3", "x4", "x5", "x6", "x7", "x8", "U_cell"]),
            r"bad\.csv: no measured channel",
        ),
        (
            lambda t: t.drop(columns=["x1", "x3", "x4", "x5", "x6", "x7", "x8", "U_cell"]).assign(x2=np.nan),
            r"bad\.csv: no measured channel",
        ),
        (
            lambda t: t.assign(x2=t.x2.where(t.index % 5 == 0, np.nan).where(t.index != 10, -2.0)),
            r"column 'x2' \(Al2O3 mass\) must be positive, row 10 has -2.0",
        ),
        (lambda t: t.assign(u2=t.u2.where(t.index != 4, np.inf)), r"column 'u2' has a non-finite value at row 4"),
        (
            lambda t: t.assign(u1=t.u1.astype(object).where(t.index != 2, "high")),
            r"column 'u1' is not numeric \(row 2: 'high'\)",
        ),
        (
            lambda t: t.assign(time_s=t.time_s.where(t.index != 5, 0.0)),
            r"'time_s' must increase within a trajectory; row 5",
        ),
        (
            lambda t: t.assign(time_s=t.time_s.where(t.index != 5, 45.0)),
            r"'time_s' must have a uniform step; the first step is 10.0 s but row 5",
        ),
        (
            lambda t: t.assign(x1=t.x1.where(t.index != 3, -1.0)),
            r"column 'x1' \(side-ledge mass\) must be positive, row 3 has -1.0",
        ),
        (
            lambda t: pd.concat([t, t[t.trajectory == 0]]),
            r"rows of a trajectory must be contiguous \(trajectory 0 reappears at row 60\)",
        ),
    ],
)
def test_bad_tables_raise_one_error_naming_file_column_and_row(table, tmp_path, corrupt, message):
    with pytest.raises(TrajectoryDataError, match=message):
        load_trajectories(_write(corrupt(table), tmp_path))


def test_unreadable_files_are_named(tmp_path):
    with pytest.raises(TrajectoryDataError, match="nothere.parquet: no such file"):
        load_trajectories(tmp_path / "nothere.parquet")
    (tmp_path / "data.xlsx").write_text("x")
    with pytest.raises(TrajectoryDataError, match=r"unknown format '\.xlsx'"):
        load_trajectories(tmp_path / "data.xlsx")
    (tmp_path / "broken.parquet").write_bytes(b"not parquet")
    with pytest.raises(TrajectoryDataError, match="broken.parquet: cannot be read as parquet"):
        load_trajectories(tmp_path / "broken.parquet")


def test_unequal_lengths_cannot_be_stacked(table):
    with pytest.raises(TrajectoryDataError, match="different lengths"):
        arrays(table[~((table.trajectory == 1) & (table.step > 15))])


@pytest.fixture()
def sparse(table, tmp_path):
    """A measured table: x6 every step, x2 every 6th step (60 s), c2 at two steps, U_cell; x7 absent."""
    t = table.drop(columns=["x7", "g1"]).assign(c2=np.nan)
    t["x2"] = t.x2.where(t.step % 6 == 0)
    t.loc[(t.trajectory == 1) & t.step.isin([3, 13]), "c2"] = [0.03, 0.031]
    path = tmp_path / "sparse.csv"
    t.drop(columns=["step"]).to_csv(path, index=False)
    return path


def test_a_sparse_table_loads_and_absent_channels_stay_absent(sparse):
    loaded = load_trajectories(sparse)
    assert "x7" not in loaded.columns
    assert loaded.x2.isna().sum() == 3 * (20 - 4)  # steps 0, 6, 12, 18 of 20 sampled
    assert loaded.u3.notna().all()


def test_the_channel_report_counts_samples_and_intervals(sparse):
    report = channel_report(load_trajectories(sparse)).set_index("channel")
    states = [f"x{i}" for i in range(1, 9)]
    assert list(report.index) == [*states, "U_cell", "U_pot", "c2", "c3", "m_tap"]
    columns = ["status", "samples", "share", "interval_s", "first_s", "last_s", "trajectories"]
    assert report.loc["x6", columns].tolist() == ["every step", 60, 1.0, 10.0, 0.0, 190.0, 3]
    assert report.loc["x2", columns].tolist() == ["sampled", 12, 0.2, 60.0, 0.0, 180.0, 3]
    assert report.loc["c2", columns].tolist() == ["sampled", 2, 2 / 60, 100.0, 30.0, 130.0, 1]
    assert report.loc["x7", "status"] == "unmeasured" and report.loc["x7", "samples"] == 0
    assert report.loc["c3", "status"] == "unmeasured"


def test_measured_channels_stack_with_their_gaps(sparse, table):
    measured = measured_trajectories(load_trajectories(sparse))
    assert measured.channels == ("x1", "x2", "x3", "x4", "x5", "x6", "x8", "U_cell", "c2")
    assert measured.values.shape == (3, 20, 9) and measured.inputs.shape == (3, 20, 5)
    assert measured.dt == 10.0
    np.testing.assert_array_equal(measured.trajectories, [0, 1, 2])
    x2 = measured.channel("x2")
    np.testing.assert_array_equal(np.flatnonzero(np.isfinite(x2[1])), [0, 6, 12, 18])
    np.testing.assert_allclose(x2[1, ::6], table.loc[(table.trajectory == 1) & (table.step % 6 == 0), "x2"], rtol=1e-15)
    np.testing.assert_array_equal(np.flatnonzero(np.isfinite(measured.channel("c2"))), [20 + 3, 20 + 13])
    np.testing.assert_allclose(measured.inputs[2, :, 1], table.loc[table.trajectory == 2, "u2"], rtol=1e-15)
    with pytest.raises(KeyError, match="'x7' was not measured"):
        measured.channel("x7")


def test_full_states_from_a_sparse_table_raise_naming_what_is_missing(sparse):
    with pytest.raises(
        TrajectoryDataError,
        match=r"every state x1..x8 at every step, but x2 \(Al2O3 mass\) has 12 of 60 steps; x7 \(side-ledge temperature\) is absent",
    ):
        arrays(load_trajectories(sparse))


def test_a_simulated_table_keeps_its_true_liquidus_and_voltage(table, tmp_path):
    path = tmp_path / "t.parquet"
    write_trajectories(table, path)
    loaded = load_trajectories(path)
    report = channel_report(loaded).set_index("channel")
    assert report.loc["U_cell", "status"] == "every step"  # a measured cell voltage under the contract
    measured = measured_trajectories(loaded)
    assert measured.channels == (*(f"x{i}" for i in range(1, 9)), "U_cell")
    np.testing.assert_array_equal(measured.values[..., :8], arrays(loaded)[0])


def test_a_model_observes_the_channels_as_the_simulator_records_them(smoke_config):
    """U_cell of a simulated table is the true model's voltage; c2, c3 are the bath fractions."""
    from costa.datasets import simulate_split
    from costa.observe import observe
    from costa.physics import model_from_config

    table, _ = simulate_split(smoke_config, "train", replicate=0)
    measured = measured_trajectories(table)
    x, u = arrays(table)
    predicted = observe(model_from_config(smoke_config["physics"])[0], x, u, ("x6", "U_cell", "c2", "c3"))
    np.testing.assert_array_equal(predicted[..., 0], x[..., 5])
    np.testing.assert_allclose(predicted[..., 1], measured.channel("U_cell"), rtol=1e-12)
    np.testing.assert_allclose(predicted[..., 2], x[..., 1] / x[..., 1:4].sum(axis=-1), rtol=1e-15)
    np.testing.assert_allclose(predicted[..., 3], x[..., 2] / x[..., 1:4].sum(axis=-1), rtol=1e-15)
    with pytest.raises(ValueError, match=r"unknown channel\(s\) \['g1'\]"):
        observe(model_from_config(smoke_config["physics"])[0], x, u, ("g1",))
