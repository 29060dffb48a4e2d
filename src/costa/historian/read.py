"""A historian's files read as stamped values: the export, the events log and the lab's samples.

- the export, long (``timestamp, tag, value[, quality]``, one row a value) or wide (``timestamp``
  and one column a tag, empty where a tag has no value);
- the events log: ``timestamp, tag, amount[, duration_s, weighed]`` (a tap's weight from the crane
  scale in ``weighed``, in the tag's unit);
- the lab's samples: ``sample_time, report_time, tag, value`` (the sample time places the value;
  the report time, hours later, only checks it).

Stamps with an offset (``2026-03-01T05:00:05Z``, ``+01:00``) are read as such; stamps without one
in the export's ``timezone``: the hour an autumn clock change repeats is told apart by the order
of the stamps (written in time order, as an export is), an hour a spring change skips stops.
Every table comes back with a ``time`` column in UTC and ``row``, its row in the file (from 0
after the header), for the messages.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..data import TrajectoryDataError, _read

__all__ = ["ExportError", "Stamped", "read_events_log", "read_export", "read_lab"]


class ExportError(TrajectoryDataError):
    """A historian file that cannot be imported: the message names the file, the tag and the row."""


@dataclass(frozen=True)
class Stamped:
    """Values ``table`` (time, tag, value, row) of one file, and what reading it dropped, per tag."""

    table: pd.DataFrame
    bad_quality: dict[str, int]
    empty: dict[str, int]


def _file(path: str | Path) -> pd.DataFrame:
    path = Path(path)
    if not path.is_file():
        raise ExportError(f"{path}: the file does not exist")
    try:
        table = _read(path)
    except TrajectoryDataError as error:
        raise ExportError(str(error)) from None
    table.columns = [str(c).strip() for c in table.columns]
    return table.reset_index(drop=True)


def _times(path: Path, stamps: pd.Series, column: str, timezone: str) -> pd.Series:
    """Stamps as UTC: those with an offset as given, the others in ``timezone``; one error naming the row."""
    text = stamps.astype("string").str.strip()
    missing = text.isna() | (text == "")
    if missing.any():
        row = int(np.flatnonzero(missing.to_numpy())[0])
        raise ExportError(f"{path}: column {column!r} has no time at row {row}")
    offset = text.str.contains(r"(?:Z|[+-]\d\d:?\d\d)$", regex=True)
    parsed = pd.Series(pd.NaT, index=stamps.index, dtype="datetime64[ns, UTC]")
    for aware in (True, False):
        rows = offset == aware
        if not rows.any():
            continue
        times = pd.to_datetime(text[rows], errors="coerce", utc=aware, format="ISO8601")
        if times.isna().any():
            row = int(times.index[times.isna()][0])
            raise ExportError(f"{path}: column {column!r} at row {row} is not a time: {text[row]!r}")
        if not aware:
            try:
                times = _localised(times, timezone)
            except (ValueError, TypeError) as error:  # pytz/zoneinfo: an hour that is twice or never in local time
                local = pd.to_datetime(text[rows], format="ISO8601")
                row = int(_first_unlocalisable(local, timezone))
                raise ExportError(
                    f"{path}: column {column!r} at row {row}: {text[row]} is not one time in {timezone} "
                    f"({type(error).__name__}: a clock change); export in UTC or with offsets"
                ) from None
        parsed[rows] = times.dt.tz_convert("UTC")
    return parsed.astype("datetime64[ns, UTC]")


def _localised(times: pd.Series, timezone: str) -> pd.Series:
    """Local stamps in UTC; the hour a clock change repeats told apart by the stamps' order (each run
    of equal stamps, as several tags stamped at once, counted once)."""
    new = (times != times.shift()).to_numpy()
    first = times[new].dt.tz_localize(timezone, ambiguous="infer", nonexistent="raise").dt.tz_convert("UTC")
    return pd.Series(first.to_numpy()[np.cumsum(new) - 1], index=times.index)


def _first_unlocalisable(local: pd.Series, timezone: str) -> int:
    for row, stamp in local.items():
        try:
            stamp.tz_localize(timezone, ambiguous=True, nonexistent="raise")
        except (ValueError, TypeError):
            return row
    return int(local.index[0])  # every stamp is one time alone: the repeated hour's order is what failed


def _values(path: Path, table: pd.DataFrame, column: str, tags: pd.Series) -> pd.Series:
    """A column as numbers; a text that is not one stops the import, naming its row and tag."""
    raw = table[column]
    values = pd.to_numeric(raw, errors="coerce")
    bad = values.isna() & raw.notna() & (raw.astype("string").str.strip() != "")
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        raise ExportError(
            f"{path}: tag {tags.iloc[row]!r} at row {row} has {raw.iloc[row]!r} in {column!r}, not a number"
        )
    return values.astype(float)


def _column(path: Path, table: pd.DataFrame, *names: str) -> str:
    found = [c for c in table.columns if c.lower() in names]
    if not found:
        raise ExportError(f"{path}: no column {' or '.join(map(repr, names))}; found {list(table.columns)}")
    return found[0]


def read_export(path: str | Path, timezone: str, good_quality: frozenset[str]) -> Stamped:
    """The export's values (time, tag, value, row), long or wide; rows of a quality not in
    ``good_quality`` and empty values dropped, and counted per tag."""
    path = Path(path)
    table = _file(path)
    stamp = _column(path, table, "timestamp", "time")
    if {"tag", "value"} <= {c.lower() for c in table.columns}:
        tag = table[_column(path, table, "tag")].astype("string").str.strip()
        value = _values(path, table, _column(path, table, "value"), tag)
        quality = next((c for c in table.columns if c.lower() == "quality"), None)
        good = (
            table[quality].astype("string").str.strip().str.lower().isin(good_quality)
            if quality
            else pd.Series(True, index=table.index)
        )
        long = pd.DataFrame({"time": _times(path, table[stamp], stamp, timezone), "tag": tag, "value": value,
                             "row": table.index, "good": good.to_numpy()})  # fmt: skip
    else:
        times = _times(path, table[stamp], stamp, timezone)
        frames = []
        for column in (c for c in table.columns if c != stamp):
            tags = pd.Series(column, index=table.index)
            frames.append(pd.DataFrame({"time": times, "tag": column, "value": _values(path, table, column, tags),
                                        "row": table.index, "good": True}))  # fmt: skip
        long = pd.concat(frames, ignore_index=True)
    bad = long[~long["good"]]
    empty = long[long["good"] & long["value"].isna()]
    kept = long[long["good"] & long["value"].notna()].drop(columns="good")
    return Stamped(
        table=kept.reset_index(drop=True),
        bad_quality=bad.groupby("tag").size().to_dict(),
        empty=empty.groupby("tag").size().to_dict(),
    )


def read_events_log(path: str | Path, timezone: str) -> pd.DataFrame:
    """The events log (time, tag, amount, duration_s, weighed, row); every event needs a time, a tag
    and an amount."""
    path = Path(path)
    table = _file(path)
    stamp = _column(path, table, "timestamp", "time")
    tag = table[_column(path, table, "tag")].astype("string").str.strip()
    amount = _values(path, table, _column(path, table, "amount"), tag)
    if amount.isna().any():
        row = int(np.flatnonzero(amount.isna().to_numpy())[0])
        raise ExportError(f"{path}: event {tag.iloc[row]!r} at row {row} has no amount")
    duration = _values(path, table, "duration_s", tag).fillna(0.0) if "duration_s" in table else 0.0
    weighed = _values(path, table, "weighed", tag) if "weighed" in table else np.nan
    return pd.DataFrame({"time": _times(path, table[stamp], stamp, timezone), "tag": tag, "amount": amount,
                         "duration_s": duration, "weighed": weighed, "row": table.index})  # fmt: skip


def read_lab(path: str | Path, timezone: str) -> pd.DataFrame:
    """The lab's samples (time: when sampled, tag, value, row); a sample with no sample time, or
    reported before it was taken, stops the import."""
    path = Path(path)
    table = _file(path)
    at, on, tags = (_column(path, table, name) for name in ("sample_time", "report_time", "tag"))
    tag = table[tags].astype("string").str.strip()
    sampled = _times(path, table[at], at, timezone)
    reported = _times(path, table[on].fillna(table[at]), on, timezone)
    early = reported < sampled
    if early.any():
        row = int(np.flatnonzero(early.to_numpy())[0])
        raise ExportError(
            f"{path}: tag {tag.iloc[row]!r} at row {row} was reported ({table[on].iloc[row]}) before it "
            f"was sampled ({table[at].iloc[row]})"
        )
    value = _values(path, table, _column(path, table, "value"), tag)
    return pd.DataFrame({"time": sampled, "tag": tag, "value": value, "row": table.index}).dropna(subset=["value"])
