"""The tidy trajectory table: one row per trajectory and step.

Columns: ``trajectory, step, time_s, x1..x8, u1..u5`` and, for simulated data,
the true liquidus temperature ``g1`` and cell voltage ``U_cell``.  Units are
stored as Parquet field metadata.  :func:`load_trajectories` reads any such table
(Parquet or CSV, simulated or measured) and checks it, raising one
:class:`TrajectoryDataError` that names the file, column and row of the first
problem (rows counted from 0, a CSV header excluded).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from .variables import DERIVED, INPUTS, MASS_STATES, MEANING, STATES, UNIT

__all__ = [
    "REQUIRED_COLUMNS",
    "TrajectoryDataError",
    "arrays",
    "load_trajectories",
    "to_table",
    "write_trajectories",
]

KEY_COLUMNS = ("trajectory", "step", "time_s")
REQUIRED_COLUMNS = ("trajectory", "time_s", *STATES, *INPUTS)


class TrajectoryDataError(ValueError):
    """A trajectory table that cannot be used, with where the problem is."""


def to_table(x: np.ndarray, u: np.ndarray, dt: float, derived: Mapping[str, np.ndarray] | None = None) -> pd.DataFrame:
    """The tidy table of states x (n, K, 8) and inputs u (n, K, 5) sampled every dt [s]."""
    n, steps = x.shape[:2]
    columns: dict[str, np.ndarray] = {
        "trajectory": np.repeat(np.arange(n, dtype=np.int32), steps),
        "step": np.tile(np.arange(steps, dtype=np.int32), n),
        "time_s": np.tile(np.arange(steps, dtype=np.float64) * dt, n),
    }
    columns.update({name: x[..., i].ravel() for i, name in enumerate(STATES)})
    columns.update({name: u[..., i].ravel() for i, name in enumerate(INPUTS)})
    columns.update({name: np.asarray(values).ravel() for name, values in (derived or {}).items()})
    return pd.DataFrame(columns)


def write_trajectories(table: pd.DataFrame, path: str | Path, provenance: Mapping | None = None) -> None:
    """Write the table as Parquet with units per column and provenance as file metadata."""
    fields = []
    for name in table.columns:
        meta = {"unit": UNIT[name], "meaning": MEANING[name]} if name in UNIT else {}
        fields.append(pa.field(name, pa.from_numpy_dtype(table[name].dtype), metadata=meta))
    schema = pa.schema(fields, metadata={"costa.provenance": json.dumps(provenance or {}, sort_keys=True)})
    pq.write_table(pa.Table.from_pandas(table, schema=schema, preserve_index=False), path)


def arrays(table: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """States (n, K, 8) and inputs (n, K, 5) of a checked table with equal-length trajectories."""
    lengths = table.groupby("trajectory", sort=True).size()
    if lengths.nunique() != 1:
        raise TrajectoryDataError(
            f"trajectories have different lengths ({lengths.min()}..{lengths.max()} rows); "
            "stacking them needs equal lengths"
        )
    n, steps = lengths.size, int(lengths.iloc[0])
    ordered = table.sort_values(["trajectory", "time_s"], kind="stable")
    x = ordered[list(STATES)].to_numpy(dtype=np.float64, copy=True).reshape(n, steps, 8)
    u = ordered[list(INPUTS)].to_numpy(dtype=np.float64, copy=True).reshape(n, steps, 5)
    return x, u


def load_trajectories(path: str | Path) -> pd.DataFrame:
    """Read and check a trajectory table from Parquet or CSV.

    Checks, in order: the file exists and parses; the required columns are there
    and numeric; every value is finite; within each trajectory time strictly
    increases with a uniform step; masses are positive.  A missing ``step``
    column is derived from the row order.  Raises :class:`TrajectoryDataError`.
    """
    path = Path(path)
    table = _read(path)
    missing = [c for c in REQUIRED_COLUMNS if c not in table.columns]
    if missing:
        raise TrajectoryDataError(
            f"{path}: missing column(s) {missing}; a trajectory table needs {list(REQUIRED_COLUMNS)}"
        )
    checked = [c for c in (*KEY_COLUMNS, *STATES, *INPUTS, *DERIVED) if c in table.columns]
    for column in checked:
        if not pd.api.types.is_numeric_dtype(table[column]):
            row = _first_row(~pd.to_numeric(table[column], errors="coerce").notna())
            raise TrajectoryDataError(
                f"{path}: column {column!r} is not numeric (row {row}: {table[column].iloc[row]!r})"
            )
        values = table[column].to_numpy(dtype=np.float64)
        if not np.isfinite(values).all():
            row = _first_row(~np.isfinite(values))
            raise TrajectoryDataError(f"{path}: column {column!r} has a non-finite value at row {row}: {values[row]}")
    _check_time(path, table)
    for column in MASS_STATES:
        bad = table[column].to_numpy() <= 0
        if bad.any():
            row = _first_row(bad)
            raise TrajectoryDataError(
                f"{path}: column {column!r} ({MEANING[column]}) must be positive, row {row} has {table[column].iloc[row]}"
            )
    if "step" not in table.columns:
        table.insert(1, "step", table.groupby("trajectory", sort=False).cumcount().astype(np.int32))
    return table


def _read(path: Path) -> pd.DataFrame:
    if not path.is_file():
        raise TrajectoryDataError(f"{path}: no such file")
    if path.stat().st_size == 0:
        raise TrajectoryDataError(f"{path}: the file is empty")
    readers = {".csv": pd.read_csv, ".parquet": pd.read_parquet, ".pq": pd.read_parquet}
    reader = readers.get(path.suffix.lower())
    if reader is None:
        raise TrajectoryDataError(f"{path}: unknown format {path.suffix!r}; use .parquet or .csv")
    try:
        table = reader(path)
    except Exception as error:  # a parser error of any kind is the user's file
        message = " ".join(str(error).split())  # one line
        raise TrajectoryDataError(f"{path}: cannot be read as {path.suffix[1:]}: {message}") from error
    _check_layout(path, table)
    return table


#: Separators a spreadsheet may have written instead of commas, by name.
_OTHER_SEPARATORS = {";": "semicolons", "\t": "tabs", "|": "vertical bars"}


def _check_layout(path: Path, table: pd.DataFrame) -> None:
    """A table read as one column (another separator than commas), or with a header and no rows."""
    if table.shape[1] == 1:
        header = str(table.columns[0])
        for separator, name in _OTHER_SEPARATORS.items():
            if separator in header:
                raise TrajectoryDataError(
                    f"{path}: the header {header[:60]!r} is one column separated by {name}; "
                    "a CSV trajectory table is separated by commas"
                )
    if table.empty:
        raise TrajectoryDataError(f"{path}: the table has columns but no rows")


def _check_time(path: Path, table: pd.DataFrame) -> None:
    trajectory = table["trajectory"].to_numpy()
    time = table["time_s"].to_numpy(dtype=np.float64)
    same = trajectory[1:] == trajectory[:-1]
    starts = np.r_[0, np.flatnonzero(~same) + 1]
    reappears = pd.Series(trajectory[starts]).duplicated().to_numpy()
    if reappears.any():
        row = int(starts[reappears][0])
        raise TrajectoryDataError(
            f"{path}: rows of a trajectory must be contiguous (trajectory {trajectory[row].item()!r} reappears at row {row})"
        )
    dt = np.diff(time)
    if (dt[same] <= 0).any():
        row = _first_row((dt <= 0) & same) + 1
        raise TrajectoryDataError(
            f"{path}: column 'time_s' must increase within a trajectory; row {row} goes from {time[row - 1]} to {time[row]}"
        )
    steps = dt[same]
    if steps.size and not np.allclose(steps, steps[0], rtol=1e-6, atol=0):
        row = _first_row(same & ~np.isclose(dt, steps[0], rtol=1e-6, atol=0)) + 1
        raise TrajectoryDataError(
            f"{path}: column 'time_s' must have a uniform step; the first step is {steps[0]} s but row {row} steps {dt[row - 1]} s"
        )


def _first_row(mask: np.ndarray) -> int:
    return int(np.flatnonzero(np.asarray(mask))[0])
