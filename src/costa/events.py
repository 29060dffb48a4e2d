"""Taps, AlF3 additions and alumina doses logged as amounts at times, turned into the model's feed rates.

A pot line logs what goes in and out as events, not as rates.  An events table (CSV or
Parquet) has one row per event:

- ``trajectory``: the record's trajectory (pot or period) it belongs to;
- ``time_s`` [s]: when it starts, on the record's clock;
- ``kind``: ``tap`` (metal removed, u4), ``alf3_addition`` (AlF3 fed, u3),
  ``alumina_dose`` (Al2O3 fed, u1) or ``anode_change`` (a new anode of ``amount_kg`` carbon set: it
  feeds no input, the model has none for the heat it takes from the bath: the historian import
  can cut the record there, and where it runs through one the findings say so, :func:`not_modelled`);
- ``amount_kg`` [kg];
- ``duration_s`` [s], optional: how long it lasts (a tap's siphoning); empty or 0 puts
  the whole amount into the step it falls in;
- ``weighed_kg`` [kg], optional, taps only: the metal the crane scale weighed in the
  crucible, where ``amount_kg`` is the tap as ordered (from the metal height and the
  tapping schedule).  It becomes a sample of the channel ``m_tap`` [kg/s], the tapping
  rate that reached the cell, at the step that holds most of the tap: a second
  measurement of u4 that tells a tap that took less than ordered from a cell that made
  less metal.  Leave it out where the logged amount already is the scale's weight.

The model holds each input over a step [t_k, t_k + dt), so :func:`event_rates` gives
each step the share of the amount delivered within it, divided by dt: the rate
integrates over the record's grid to the amount.  The rates add to the record's logged
u1, u3 and u4 (a record that gets a feed only as events logs 0 there).
:func:`load_trajectories_with_events` reads and checks both files; a problem raises one
:class:`~costa.data.TrajectoryDataError` naming the file, the column and the row (rows
counted from 0 after a CSV header).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

# the trajectory table's reader and checks serve the events table too
from .data import TrajectoryDataError, _check_numeric, _first_row, _read, load_trajectories, time_step

__all__ = [
    "EVENT_COLUMNS",
    "EVENT_KINDS",
    "EventKind",
    "event_rates",
    "load_trajectories_with_events",
    "not_modelled",
    "read_events",
    "weighed_taps",
]

EVENT_COLUMNS = ("trajectory", "time_s", "kind", "amount_kg", "duration_s", "weighed_kg")
REQUIRED_EVENT_COLUMNS = EVENT_COLUMNS[:4]  # duration_s and weighed_kg are optional


@dataclass(frozen=True)
class EventKind:
    """What one kind of event feeds (``input``), and the amounts [kg] and durations [s] a real cell has."""

    input: str | None  # None: it feeds no input
    meaning: str
    amount_kg: tuple[float, float]
    duration_s: tuple[float, float]


#: The check ranges are generous plausible bounds, not one smelter's practice.  A tap: 0.1-5 t over
#: 1-60 min (a pot makes about 1.07 t a day at 140 kA and 95 % current efficiency, by Faraday's law,
#: tapped once or twice a day; the paper's cell, which makes half of that, run as a pot line with a
#: feeder short of alumina, tapped 361 kg; Qatalum's 300 kA pots have a standard tap of 1903 kg; a
#: tap in t logged as kg reads below 0.1 t).  An AlF3 addition: up to 100 kg (the largest
#: of the simulated cells' AlF3 impulses, 10 kg/s for one 10 s step).  An alumina dose: up to 10 kg (a
#: point feeder's shot is a few kg).  Doses and additions may last up to an hour, or no time at all.
EVENT_KINDS: dict[str, EventKind] = {
    "tap": EventKind("u4", "metal tapped", (100.0, 5000.0), (60.0, 3600.0)),
    "alf3_addition": EventKind("u3", "AlF3 added", (0.0, 100.0), (0.0, 3600.0)),
    "alumina_dose": EventKind("u1", "Al2O3 added", (0.0, 10.0), (0.0, 3600.0)),
    #: a prebaked anode is 0.3-2 t of carbon; set in minutes
    "anode_change": EventKind(None, "a new anode set", (300.0, 2000.0), (0.0, 3600.0)),
}
#: what the findings say where the events hold kinds that feed nothing (docs/own-data.md measures it)
NOT_MODELLED = {
    "anode_change": "anode changes, which the model does not describe (it has no input for the heat a cold anode "
    "takes from the bath): where the record runs through them they can flag a correct model (a pot hiding nothing "
    "else, a new anode every 2 days: the pot voltage at 1.12 times its noise variance); cut the record at each "
    "(historian.anode_change_after_s; 12 h passed that pot)",
}


def load_trajectories_with_events(
    record: str | Path, events: str | Path, unlogged: Mapping[str, float] | None = None
) -> pd.DataFrame:
    """A trajectory table (:func:`costa.data.load_trajectories`, ``unlogged`` inputs held at their stated
    values) with its events' rates [kg/s] added to u1, u3, u4, and its weighed taps as ``m_tap``."""
    table = load_trajectories(record, unlogged)
    found = read_events(events)
    _check_against_record(Path(events), found, table, Path(record))
    table = table.copy()
    for name, rate in event_rates(found, table).items():
        table[name] = table[name] + rate
    if found["weighed_kg"].notna().any():
        if "m_tap" in table.columns:
            raise TrajectoryDataError(
                f"{events}: column 'weighed_kg' and {record}'s column 'm_tap' both weigh the taps"
            )
        table["m_tap"] = weighed_taps(found, table)
    return table


def read_events(path: str | Path) -> pd.DataFrame:
    """Read and check an events table: the columns, known kinds, positive amounts within their kind's range,
    durations within it, and time not decreasing within a trajectory.  ``duration_s`` absent or empty is 0."""
    path = Path(path)
    events = _read(path)
    missing = [c for c in REQUIRED_EVENT_COLUMNS if c not in events.columns]
    if missing:
        raise TrajectoryDataError(f"{path}: missing column(s) {missing}; an events table needs {list(EVENT_COLUMNS)}")
    events = events.assign(duration_s=events.get("duration_s", 0.0), weighed_kg=events.get("weighed_kg", np.nan))
    _check_numeric(path, events, ("trajectory", "time_s", "amount_kg", "duration_s", "weighed_kg"))
    for column in REQUIRED_EVENT_COLUMNS:
        if events[column].isna().any():
            row = _first_row(events[column].isna())
            raise TrajectoryDataError(f"{path}: column {column!r} has no value at row {row} (every event needs one)")
    events["duration_s"] = events["duration_s"].fillna(0.0)
    unknown = ~events["kind"].isin(list(EVENT_KINDS))
    if unknown.any():
        row = _first_row(unknown)
        raise TrajectoryDataError(
            f"{path}: column 'kind' has the unknown kind {events['kind'].iloc[row]!r} at row {row}; "
            f"known: {', '.join(EVENT_KINDS)}"
        )
    _check_amounts(path, events)
    _check_weights(path, events)
    _check_durations(path, events)
    _check_time_order(path, events)
    return events


def event_rates(events: pd.DataFrame, table: pd.DataFrame) -> dict[str, np.ndarray]:
    """The rate [kg/s] at each row of the checked ``table`` that the checked ``events`` feed, per input."""
    dt = time_step(table)
    delivered = {kind.input: np.zeros(len(table)) for kind in EVENT_KINDS.values() if kind.input}
    for event, rows, share in _event_steps(events, table):
        if EVENT_KINDS[event.kind].input:
            delivered[EVENT_KINDS[event.kind].input][rows] += event.amount_kg * share
    return {name: amount / dt for name, amount in delivered.items()}


def not_modelled(events: pd.DataFrame) -> str:
    """What the checked ``events`` hold that the model does not describe, in words ("" where nothing)."""
    counts = events["kind"].value_counts()
    return "; ".join(
        f"the events hold {counts[kind]} {words}" for kind, words in NOT_MODELLED.items() if kind in counts
    )


def weighed_taps(events: pd.DataFrame, table: pd.DataFrame) -> np.ndarray:
    """``m_tap`` at each row of the checked ``table`` [kg/s]: each weighed tap's rate, weighed_kg times its share
    in the step that holds most of it over dt; NaN elsewhere."""
    dt = time_step(table)
    weighed = np.full(len(table), np.nan)
    for event, rows, share in _event_steps(events, table):
        if event.kind == "tap" and np.isfinite(event.weighed_kg):
            most = int(np.argmax(share))
            weighed[rows[most]] = event.weighed_kg * share[most] / dt
    return weighed


def _event_steps(events: pd.DataFrame, table: pd.DataFrame):
    """(event, rows of ``table``, share of its amount delivered in each) for every event."""
    dt = time_step(table)
    time = table["time_s"].to_numpy(dtype=np.float64)
    rows_of = table.reset_index(drop=True).groupby("trajectory").indices
    # step k of a trajectory runs from edges[k] to edges[k + 1]
    edges_of = {t: np.append(time[rows], time[rows[-1]] + dt) for t, rows in rows_of.items()}
    for event in events.itertuples():
        rows, edges = rows_of[event.trajectory], edges_of[event.trajectory]
        first = np.searchsorted(edges, event.time_s, side="right") - 1
        last = max(np.searchsorted(edges, event.time_s + event.duration_s, side="left"), first + 1)
        share = _delivered_share(edges[first : last + 1], event.time_s, event.duration_s)
        yield event, rows[first:last], np.diff(share)


def _delivered_share(times: np.ndarray, start: float, duration: float) -> np.ndarray:
    """The share of an event's amount delivered by each of ``times`` [s]: a ramp over its duration, or a step."""
    if duration > 0:
        return np.clip((times - start) / duration, 0.0, 1.0)
    return (times > start).astype(np.float64)


# ---------------------------------------------------------------- the checks
def _check_amounts(path: Path, events: pd.DataFrame) -> None:
    amount = events["amount_kg"].to_numpy(dtype=np.float64)
    if (amount <= 0).any():
        row = _first_row(amount <= 0)
        raise TrajectoryDataError(f"{path}: column 'amount_kg' must be positive, row {row} has {amount[row]:g}")
    _check_kind_range(path, events, "amount_kg", "kg")


def _check_weights(path: Path, events: pd.DataFrame) -> None:
    """A weight only for taps, positive and within a tap's range of amounts."""
    weighed = events["weighed_kg"].notna().to_numpy()
    not_tap = weighed & (events["kind"] != "tap").to_numpy()
    if not_tap.any():
        row = _first_row(not_tap)
        raise TrajectoryDataError(
            f"{path}: column 'weighed_kg' has a value at row {row}, a {events['kind'].iloc[row]!r}: only taps are weighed"
        )
    low, high = EVENT_KINDS["tap"].amount_kg
    value = events["weighed_kg"].to_numpy(dtype=np.float64)
    outside = weighed & ((value < low) | (value > high))
    if outside.any():
        row = _first_row(outside)
        raise TrajectoryDataError(
            f"{path}: column 'weighed_kg' must lie in {low:g}-{high:g} kg for a tap, row {row} has {value[row]:g}"
        )


def _check_durations(path: Path, events: pd.DataFrame) -> None:
    duration = events["duration_s"].to_numpy(dtype=np.float64)
    if (duration < 0).any():
        row = _first_row(duration < 0)
        raise TrajectoryDataError(f"{path}: column 'duration_s' must not be negative, row {row} has {duration[row]:g}")
    _check_kind_range(path, events, "duration_s", "s")


def _check_kind_range(path: Path, events: pd.DataFrame, column: str, unit: str) -> None:
    """Each kind's plausible range of ``column`` (:data:`EVENT_KINDS`)."""
    low, high = np.array([getattr(EVENT_KINDS[kind], column) for kind in events["kind"]]).reshape(-1, 2).T
    values = events[column].to_numpy(dtype=np.float64)
    outside = (values < low) | (values > high)
    if outside.any():
        row = _first_row(outside)
        raise TrajectoryDataError(
            f"{path}: column {column!r} must lie in {low[row]:g}-{high[row]:g} {unit} for kind "
            f"{events['kind'].iloc[row]!r}, row {row} has {values[row]:g}"
        )


def _check_time_order(path: Path, events: pd.DataFrame) -> None:
    time = events["time_s"].to_numpy(dtype=np.float64)
    before = events.groupby("trajectory", sort=False)["time_s"].shift().to_numpy(dtype=np.float64)
    backwards = time < before  # NaN (a trajectory's first event) compares False
    if backwards.any():
        row = _first_row(backwards)
        raise TrajectoryDataError(
            f"{path}: column 'time_s' must not decrease within a trajectory; row {row} goes back from "
            f"{before[row]:g} to {time[row]:g} (list each trajectory's events in time order)"
        )


def _check_against_record(path: Path, events: pd.DataFrame, table: pd.DataFrame, record: Path) -> None:
    """Every event belongs to a trajectory of the record and lies within its span [first sample, last + dt)."""
    dt = time_step(table)
    span = table.groupby("trajectory")["time_s"].agg(["min", "max"])
    known = events["trajectory"].isin(span.index).to_numpy()
    if not known.all():
        row = _first_row(~known)
        raise TrajectoryDataError(
            f"{path}: column 'trajectory' at row {row} names trajectory {events['trajectory'].iloc[row]:g}, "
            f"which {record} does not have"
        )
    start = events["time_s"].to_numpy(dtype=np.float64)
    end = start + events["duration_s"].to_numpy(dtype=np.float64)
    first = span["min"].reindex(events["trajectory"]).to_numpy()
    stop = span["max"].reindex(events["trajectory"]).to_numpy() + dt
    outside = (start < first) | (end > stop) | (start >= stop)
    if outside.any():
        row = _first_row(outside)
        event = events.iloc[row]
        lasting = f"from {start[row]:g} s to {end[row]:g} s" if end[row] > start[row] else f"at {start[row]:g} s"
        raise TrajectoryDataError(
            f"{path}: column 'time_s' at row {row}: the {event['kind']} {lasting} lies outside trajectory "
            f"{event['trajectory']:g} of {record} ({first[row]:g} s to {stop[row]:g} s)"
        )
