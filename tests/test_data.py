"""The trajectory table: round trip, units, and one clear error per kind of bad input."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

from costa.data import TrajectoryDataError, arrays, load_trajectories, to_table, write_trajectories


@pytest.fixture()
def table(rng) -> pd.DataFrame:
    x = rng.uniform(100, 1000, (3, 20, 8))
    u = rng.uniform(0, 1, (3, 20, 5))
    return to_table(x, u, 10.0, {"g1": rng.uniform(960, 970, (3, 20))})


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
    table.drop(columns=["step", "g1"]).to_csv(path, index=False)
    loaded = load_trajectories(path)
    np.testing.assert_array_equal(loaded["step"], table["step"])


def _write(table: pd.DataFrame, tmp_path, name="bad.csv"):
    path = tmp_path / name
    table.to_csv(path, index=False)
    return path


@pytest.mark.parametrize(
    ("corrupt", "message"),
    [
        (lambda t: t.drop(columns=["x4"]), r"bad\.csv: missing column\(s\) \['x4'\]"),
        (
            lambda t: t.assign(x6=t.x6.where(t.index != 7, np.nan)),
            r"bad\.csv: column 'x6' has a non-finite value at row 7",
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
