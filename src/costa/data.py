"""The tidy trajectory table: one row per trajectory and step.

The data contract (``docs/own-data.md`` explains it for users):

- ``trajectory``, ``time_s`` and the inputs ``u1..u5`` at every step: the inputs are
  logged commands and never missing; ``time_s`` strictly increases with a uniform
  step within each trajectory, and a trajectory's rows are contiguous.  ``step`` is
  optional (derived from the row order).
- the measurement channels, each optional: the states ``x1..x8`` and the outputs
  ``U_cell`` (cell voltage, V), ``U_pot`` (pot voltage, V), ``c2`` and ``c3`` (the
  bath's Al2O3 and AlF3 mass fractions).  NaN (an empty CSV field) marks a step where
  a channel was not sampled; a column that is absent, or has no value at all, is
  unmeasured.  At least one channel must be measured; masses must be positive and the
  pot voltage within 2.5-7 V (``PLAUSIBLE_RANGE``) where present.
- simulated tables also carry ``g1``, the true liquidus temperature, for reference.

:func:`load_trajectories` reads such a table (Parquet or CSV) and checks it,
raising one :class:`TrajectoryDataError` that names the file, column and row of
the first problem (rows counted from 0, a CSV header excluded).  It keeps absent
channels absent.  :func:`channel_report` says what was measured how often;
:func:`measured_trajectories` stacks the measured channels with their NaN, and
:func:`arrays` the full states of a table that has every state at every step.
Units are stored as Parquet field metadata by :func:`write_trajectories`.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from .variables import AUXILIARY, CHANNELS, INPUTS, MASS_STATES, MEANING, PLAUSIBLE_RANGE, STATES, UNIT

__all__ = [
    "CHANNELS",
    "REQUIRED_COLUMNS",
    "MeasuredTrajectories",
    "TrajectoryDataError",
    "arrays",
    "channel_report",
    "format_channel_report",
    "incomplete_states",
    "load_trajectories",
    "measured_channels",
    "measured_trajectories",
    "read_provenance",
    "time_step",
    "to_table",
    "write_trajectories",
]

KEY_COLUMNS = ("trajectory", "step", "time_s")
REQUIRED_COLUMNS = ("trajectory", "time_s", *INPUTS)


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


def read_provenance(path: str | Path) -> dict[str, Any]:
    """The provenance :func:`write_trajectories` stored with a Parquet table ({} where none: a CSV has none)."""
    if Path(path).suffix.lower() != ".parquet":
        return {}
    metadata = pq.read_schema(path).metadata or {}
    return json.loads(metadata.get(b"costa.provenance", b"{}"))


def load_trajectories(path: str | Path, unlogged: Mapping[str, float] | None = None) -> pd.DataFrame:
    """Read and check a trajectory table from Parquet or CSV (the contract in the module docstring).

    ``unlogged``: inputs the record does not log, each held at a stated value (its column absent
    or empty is filled with it; a column partly logged keeps its values and gets it where empty).

    Checks, in order: the file exists and parses; ``trajectory``, ``time_s`` and
    ``u1..u5`` are there; the known columns are numeric; keys and inputs have a
    finite value in every row; channels are finite where sampled; at least one
    channel is measured; time strictly increases with a uniform step within each
    trajectory; masses are positive and channels with a plausible range
    (``PLAUSIBLE_RANGE``) within it where sampled.  A missing ``step`` column is
    derived from the row order.  Raises :class:`TrajectoryDataError`.
    """
    path = Path(path)
    table = _read(path)
    for name, value in (unlogged or {}).items():
        table[name] = table[name].fillna(value) if name in table.columns else float(value)
    _check_required_columns(path, table)
    known = [c for c in (*KEY_COLUMNS, *INPUTS, *CHANNELS, *AUXILIARY) if c in table.columns]
    _check_numeric(path, table, known)
    _check_every_row(path, table, [c for c in (*KEY_COLUMNS, *INPUTS) if c in table.columns])
    _check_finite_where_sampled(path, table, [c for c in (*CHANNELS, *AUXILIARY) if c in table.columns])
    _check_some_channel(path, table)
    _check_time(path, table)
    _check_positive_masses(path, table)
    _check_plausible_range(path, table)
    if "step" not in table.columns:
        table.insert(1, "step", table.groupby("trajectory", sort=False).cumcount().astype(np.int32))
    return table


def measured_channels(table: pd.DataFrame) -> tuple[str, ...]:
    """The channels (states, then outputs, in the order of ``CHANNELS``) with at least one sample."""
    return tuple(c for c in CHANNELS if c in table.columns and table[c].notna().any())


def time_step(table: pd.DataFrame) -> float:
    """The uniform sampling step dt [s] of a checked table."""
    first = table["trajectory"].to_numpy()
    same = np.flatnonzero(first[1:] == first[:-1])
    if same.size == 0:
        raise TrajectoryDataError("every trajectory has a single row; a time step needs two samples")
    time = table["time_s"].to_numpy(dtype=np.float64)
    return float(time[same[0] + 1] - time[same[0]])


def channel_report(table: pd.DataFrame) -> pd.DataFrame:
    """What was measured how often: one row per channel of ``CHANNELS`` (unmeasured ones too).

    Columns: channel, meaning, unit, status ("every step", "sampled" or
    "unmeasured"), samples (count of values), share (of all rows), interval_s (the
    median time between consecutive samples within a trajectory [s]; NaN with
    fewer than two in every trajectory), first_s and last_s (the earliest and the
    latest time_s of a sample [s]), trajectories (how many have a sample).
    """
    rows = []
    time = table["time_s"].to_numpy(dtype=np.float64)
    trajectory = table["trajectory"].to_numpy()
    for channel in CHANNELS:
        sampled = table[channel].notna().to_numpy() if channel in table.columns else np.zeros(len(table), bool)
        t, owner = time[sampled], trajectory[sampled]
        gaps = np.diff(t)[owner[1:] == owner[:-1]]
        count = int(sampled.sum())
        rows.append(
            {
                "channel": channel,
                "meaning": MEANING[channel],
                "unit": UNIT[channel],
                "status": "unmeasured" if count == 0 else "every step" if count == len(table) else "sampled",
                "samples": count,
                "share": count / len(table) if len(table) else 0.0,
                "interval_s": float(np.median(gaps)) if gaps.size else np.nan,
                "first_s": float(t.min()) if count else np.nan,
                "last_s": float(t.max()) if count else np.nan,
                "trajectories": int(pd.unique(owner).size),
            }
        )
    return pd.DataFrame(rows)


def format_channel_report(report: pd.DataFrame) -> str:
    """The channel report as one readable line per channel (for logs and findings)."""
    lines = []
    for r in report.itertuples():
        where = f"{r.channel} ({r.meaning}, {r.unit})"
        if r.status == "unmeasured":
            lines.append(f"{where}: not measured")
            continue
        every = f"every {r.interval_s:g} s" if np.isfinite(r.interval_s) else "one sample per trajectory"
        lines.append(
            f"{where}: {r.samples} samples ({r.share:.0%} of steps) in {r.trajectories} trajectories, {every}, "
            f"from {r.first_s:g} s to {r.last_s:g} s"
        )
    return "\n".join(lines)


@dataclass(frozen=True)
class MeasuredTrajectories:
    """The measured channels of equal-length trajectories, stacked.

    ``values`` (n, K, C) holds the channels ``channels`` (C names, in the order of
    ``CHANNELS``) with NaN where a channel was not sampled; ``inputs`` (n, K, 5) the
    inputs u1..u5; ``trajectories`` (n,) the ids; ``dt`` the time step [s].
    """

    values: np.ndarray
    channels: tuple[str, ...]
    inputs: np.ndarray
    trajectories: np.ndarray
    dt: float

    def channel(self, name: str) -> np.ndarray:
        """One channel (n, K), NaN where not sampled."""
        if name not in self.channels:
            raise KeyError(f"channel {name!r} was not measured; measured: {list(self.channels)}")
        return self.values[..., self.channels.index(name)]


def measured_trajectories(table: pd.DataFrame) -> MeasuredTrajectories:
    """The measured channels (with NaN) and inputs of a checked table with equal-length trajectories."""
    channels = measured_channels(table)
    ordered = _ordered(table)
    return MeasuredTrajectories(
        _stack(ordered, channels),
        channels,
        _stack(ordered, INPUTS),
        np.asarray(pd.unique(ordered["trajectory"])),
        time_step(ordered),
    )


def arrays(table: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """States (n, K, 8) and inputs (n, K, 5) of a checked table with every state at every step
    and equal-length trajectories (a sparse table raises, naming what is missing)."""
    incomplete = incomplete_states(table)
    if incomplete:
        raise TrajectoryDataError("this needs every state x1..x8 at every step, but " + "; ".join(incomplete))
    ordered = _ordered(table)
    return _stack(ordered, STATES), _stack(ordered, INPUTS)


def incomplete_states(table: pd.DataFrame) -> list[str]:
    """One phrase per state that is absent or not sampled at every step (empty for a full table)."""
    problems = []
    for state in STATES:
        if state not in table.columns:
            problems.append(f"{state} ({MEANING[state]}) is absent")
        elif table[state].isna().any():
            problems.append(f"{state} ({MEANING[state]}) has {table[state].notna().sum()} of {len(table)} steps")
    return problems


def _ordered(table: pd.DataFrame) -> pd.DataFrame:
    lengths = table.groupby("trajectory", sort=True).size()
    if lengths.nunique() != 1:
        raise TrajectoryDataError(
            f"trajectories have different lengths ({lengths.min()}..{lengths.max()} rows); "
            "stacking them needs equal lengths"
        )
    return table.sort_values(["trajectory", "time_s"], kind="stable")


def _stack(ordered: pd.DataFrame, columns: Sequence[str]) -> np.ndarray:
    """Columns of a table ordered by trajectory and time, as (n, K, len(columns)) float64."""
    n = ordered["trajectory"].nunique()
    values = ordered[list(columns)].to_numpy(dtype=np.float64, copy=True)
    return values.reshape(n, len(ordered) // n if n else 0, len(columns))


# ---------------------------------------------------------------- the checks
def _check_required_columns(path: Path, table: pd.DataFrame) -> None:
    missing = [c for c in REQUIRED_COLUMNS if c not in table.columns]
    if missing:
        raise TrajectoryDataError(
            f"{path}: missing column(s) {missing}; a trajectory table needs {list(REQUIRED_COLUMNS)} "
            f"and at least one of the measured channels {list(CHANNELS)}{_unlogged_hint(missing)}"
        )


#: a cell's typical inputs at 140 kA (the nominal feed, AlF3 and tapping rates equal consumption and production)
TYPICAL_INPUTS = {"u1": 0.024, "u2": 140000.0, "u3": 0.0005, "u4": 0.0062, "u5": 0.05}


def _unlogged_hint(columns: Sequence[str]) -> str:
    inputs = [c for c in columns if c in INPUTS]
    if not inputs:
        return ""
    return (
        f"; an input your line does not log can be declared in discovery.user_data.unlogged_inputs with the "
        f"value it is held at (e.g. {{{inputs[0]}: {TYPICAL_INPUTS[inputs[0]]}}}, in {UNIT[inputs[0]]})"
    )


def _check_numeric(path: Path, table: pd.DataFrame, columns: Sequence[str]) -> None:
    for column in columns:
        if not pd.api.types.is_numeric_dtype(table[column]):
            row = _first_row(table[column].notna() & pd.to_numeric(table[column], errors="coerce").isna())
            raise TrajectoryDataError(
                f"{path}: column {column!r} is not numeric (row {row}: {table[column].iloc[row]!r})"
            )


def _check_every_row(path: Path, table: pd.DataFrame, columns: Sequence[str]) -> None:
    """Keys and inputs: a finite value in every row."""
    for column in columns:
        values = table[column].to_numpy(dtype=np.float64)
        if np.isnan(values).any():
            row = _first_row(np.isnan(values))
            what = "the inputs u1..u5 are logged commands, needed at every step" if column in INPUTS else "a key"
            raise TrajectoryDataError(
                f"{path}: column {column!r} has no value at row {row} ({what}){_unlogged_hint([column])}"
            )
        if not np.isfinite(values).all():
            row = _first_row(~np.isfinite(values))
            raise TrajectoryDataError(f"{path}: column {column!r} has a non-finite value at row {row}: {values[row]}")


def _check_finite_where_sampled(path: Path, table: pd.DataFrame, columns: Sequence[str]) -> None:
    """Channels: NaN marks a step without a sample; anything else must be finite."""
    for column in columns:
        values = table[column].to_numpy(dtype=np.float64)
        bad = np.isinf(values)
        if bad.any():
            row = _first_row(bad)
            raise TrajectoryDataError(
                f"{path}: column {column!r} has a non-finite value at row {row}: {values[row]} "
                "(leave a step that was not sampled empty, or NaN)"
            )


def _check_some_channel(path: Path, table: pd.DataFrame) -> None:
    if not measured_channels(table):
        raise TrajectoryDataError(
            f"{path}: no measured channel: a trajectory table needs at least one of {list(CHANNELS)} "
            f"with a value (columns: {list(table.columns)})"
        )


def _check_positive_masses(path: Path, table: pd.DataFrame) -> None:
    for column in MASS_STATES:
        if column not in table.columns:
            continue
        bad = table[column].to_numpy(dtype=np.float64) <= 0  # NaN compares False: not sampled is fine
        if bad.any():
            row = _first_row(bad)
            raise TrajectoryDataError(
                f"{path}: column {column!r} ({MEANING[column]}) must be positive, row {row} has {table[column].iloc[row]}"
            )


def _check_plausible_range(path: Path, table: pd.DataFrame) -> None:
    for column, (low, high) in PLAUSIBLE_RANGE.items():
        if column not in table.columns:
            continue
        values = table[column].to_numpy(dtype=np.float64)
        bad = (values < low) | (values > high)  # NaN compares False: not sampled is fine
        if bad.any():
            row = _first_row(bad)
            raise TrajectoryDataError(
                f"{path}: column {column!r} ({MEANING[column]}) must lie in {low:g}-{high:g} {UNIT[column]} "
                f"where sampled, row {row} has {values[row]:g} (a wrong unit, or a sample to leave empty?)"
            )


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
                    "a CSV table is separated by commas"
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
