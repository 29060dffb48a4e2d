"""A historian's stamped values onto the model's step: the data contract's record and events.

Each signal's values (converted to its target's unit) are averaged within each step
[t_k, t_k + step_s) of one grid from the first line-current value on; a step with no value stays
empty (no value is carried across a gap).  The logged inputs (the line current u2, the
anode-cathode distance u5 where mapped) must have a value at every step: a gap of up to
``max_gap_s`` holds the last value, a longer one cuts the record there, and each stretch between
cuts is a trajectory (or as many whole ones of ``trajectory_s`` as it holds).  An anode effect
(the voltage above ``anode_effect_v``) leaves the voltage empty from its start to
``anode_effect_after_s`` after its end; a voltage still outside the contract's range, or a mass
not positive, is left empty too.  An anode change (a cold anode set, an event the model has no
input for) cuts the record where ``anode_change_after_s`` > 0: its stretch ends at the change and
the next starts that long after it, from the state the estimator finds there.  Events (feeder
shots, AlF3 additions, taps, anode changes) go on the record's
clock (``time_s`` from the grid's start) in the trajectory they fall in; one outside every
trajectory (in a cut or a left-over stretch) is left out.  Every such choice is counted in the
report (:mod:`.report`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..variables import CHANNELS, MASS_STATES, PLAUSIBLE_RANGE
from .read import ExportError, read_events_log, read_export, read_lab
from .tags import TagMap

__all__ = ["GridSettings", "Imported", "import_historian"]

VOLTAGES = ("U_pot", "U_cell")
LOGGED_INPUTS = ("u2", "u5")


@dataclass(frozen=True, kw_only=True)
class GridSettings:
    """How the stamped values are put on the model's step (seconds; volts)."""

    timezone: str = "UTC"  # where stamps without an offset were written
    step_s: float = 10.0
    max_gap_s: float = 600.0
    anode_effect_v: float = 8.0
    anode_effect_after_s: float = 600.0
    anode_change_after_s: float = 0.0  # 0: an anode change does not cut the record
    trajectory_s: float | None = None  # each stretch cut into whole trajectories this long (the rest left out)


@dataclass(frozen=True)
class Imported:
    """The data contract's ``record`` and ``events`` tables and the ``report`` (a JSON-able dict) of one import."""

    record: pd.DataFrame
    events: pd.DataFrame
    report: dict


def import_historian(
    export: str | Path, tags: TagMap, settings: GridSettings, events: str | Path | None = None,
    lab: str | Path | None = None,
) -> Imported:  # fmt: skip
    """Read an export (and its events log and lab samples, where given) and put it on the grid."""
    read = read_export(export, settings.timezone, tags.good_quality)
    _check_tags(Path(export), read.table, tags, allowed=set(tags.signals) | tags.ignore)
    values = read.table[~read.table["tag"].isin(tags.ignore)]
    _check_order(Path(export), values)
    if lab is not None:
        samples = read_lab(lab, settings.timezone)
        _check_tags(Path(lab), samples, tags, allowed=set(tags.signals))
        values = pd.concat([values, samples], ignore_index=True)
    logged = read_events_log(events, settings.timezone) if events is not None else None
    if logged is not None:
        _check_tags(Path(events), logged, tags, allowed=set(tags.events))
    grid = _Grid(values, tags, settings, Path(export))
    changes = pd.Series([], dtype="datetime64[ns, UTC]")
    if logged is not None:
        changes = logged["time"][logged["tag"].map(lambda t: tags.events[t].kind == "anode_change").to_numpy(bool)]
    record, report = grid.record(changes)
    placed, report["events"] = grid.events(logged, record) if logged is not None else (_no_events(), {})
    report["bad_quality"], report["empty_values"] = read.bad_quality, read.empty
    return Imported(record=record, events=placed, report=report)


def _check_tags(path: Path, table: pd.DataFrame, tags: TagMap, allowed: set[str]) -> None:
    unknown = ~table["tag"].isin(allowed)
    if unknown.any():
        row = table["row"][unknown].iloc[0]
        tag = table["tag"][unknown].iloc[0]
        where = "an event: events come from the events log" if tag in tags.events else "not in the tag map"
        where = "a signal: signals come from the export or the lab's file" if tag in tags.signals else where
        raise ExportError(
            f"{path}: tag {tag!r} at row {row} is {where} ({tags.path}; list a tag to skip under 'ignore')"
        )


def _check_order(path: Path, values: pd.DataFrame) -> None:
    """A tag's stamps, in the order the export lists them, do not go back in time."""
    ordered = values.sort_values("row", kind="stable")
    before = ordered.groupby("tag", sort=False)["time"].shift()
    backwards = (ordered["time"] < before).to_numpy()
    if backwards.any():
        i = int(np.flatnonzero(backwards)[0])
        r = ordered.iloc[i]
        raise ExportError(
            f"{path}: tag {r['tag']!r} at row {r['row']} goes back in time, from {before.iloc[i]} to {r['time']} (UTC)"
        )


def _no_events() -> pd.DataFrame:
    return pd.DataFrame(
        {c: pd.Series(dtype=float) for c in ("trajectory", "time_s", "amount_kg", "duration_s", "weighed_kg")}
    ).assign(kind=pd.Series(dtype=object))[["trajectory", "time_s", "kind", "amount_kg", "duration_s", "weighed_kg"]]


class _Grid:
    """One export's values on the step grid from its first line-current value."""

    def __init__(self, values: pd.DataFrame, tags: TagMap, settings: GridSettings, path: Path):
        self.tags, self.settings = tags, settings
        current = values[values["tag"].isin([t for t, s in tags.signals.items() if s.target == "u2"])]
        if current.empty:
            raise ExportError(f"{path}: no value of the line current (u2) in the export: nothing to put on a grid")
        self.start = current["time"].min().floor(f"{settings.step_s}s")
        stop = values["time"].max()
        self.steps = int((stop - self.start).total_seconds() // settings.step_s) + 1
        repeated = values.duplicated(["tag", "time", "value"])  # a value sent twice counts once
        self.duplicates = repeated.groupby(values["tag"]).sum().astype(int)
        values = values[~repeated]
        step = ((values["time"] - self.start).dt.total_seconds() // settings.step_s).astype(int)
        self.values = values.assign(step=step)[step >= 0]

    def _averaged(self, signal) -> np.ndarray:
        """The signal's values in its target's unit, averaged within each step; NaN where none."""
        mine = self.values[self.values["tag"] == signal.tag]
        out = np.full(self.steps, np.nan)
        if not mine.empty:
            means = pd.Series(signal.convert(mine["value"].to_numpy(float))).groupby(mine["step"].to_numpy()).mean()
            out[means.index.to_numpy()] = means.to_numpy()
        return out

    def record(self, changes: pd.Series) -> tuple[pd.DataFrame, dict]:
        """The contract's record (trajectory, time_s, u1..u5, channels) and the report so far, cut at
        the anode ``changes`` (UTC times) where ``anode_change_after_s`` > 0."""
        s = self.settings
        columns = {sig.target: self._averaged(sig) for sig in self.tags.signals.values()}
        report: dict = {"start_utc": str(self.start), "step_s": s.step_s, "steps": self.steps, "tags": {}}
        report["anode_effects"] = self._anode_effects(columns)
        report["blanked"] = self._blank_implausible(columns)
        held = self._hold(columns)
        valid = np.all([np.isfinite(columns[u]) for u in LOGGED_INPUTS if u in columns], axis=0)
        report["cuts"] = self._cuts(valid)
        report["anode_change_cuts"] = self._cut_at_anode_changes(changes, valid)
        report["held_steps"] = held
        trajectory, report["left_over_steps"] = self._trajectories(valid)
        valid &= trajectory >= 0
        rows = np.flatnonzero(valid)
        table = pd.DataFrame({"trajectory": trajectory[rows], "time_s": rows * s.step_s})
        for name in ("u1", "u2", "u3", "u4", "u5"):
            if name in columns:
                table[name] = columns[name][rows]
            elif name in ("u1", "u3", "u4"):
                table[name] = 0.0  # fed and tapped as events (the events table adds their rates)
        for channel in CHANNELS:
            if channel in columns:
                table[channel] = columns[channel][rows]
        counts = self.values["tag"].value_counts()
        for tag, sig in self.tags.signals.items():
            report["tags"][tag] = {
                "to": sig.target, "unit": sig.unit, "values": int(counts.get(tag, 0)),
                "duplicates": int(self.duplicates.get(tag, 0)),
                "steps_with_a_value": int(np.isfinite(columns[sig.target]).sum()),
            }  # fmt: skip
        report["trajectories"] = int(table["trajectory"].nunique())
        report["rows"] = len(table)
        return table, report

    def _anode_effects(self, columns: dict[str, np.ndarray]) -> list[dict]:
        """Blank the voltage from each anode effect's start to ``anode_effect_after_s`` after its end."""
        s = self.settings
        effects = []
        for name in VOLTAGES:
            if name not in columns:
                continue
            high = np.nan_to_num(columns[name]) > s.anode_effect_v
            after = int(round(s.anode_effect_after_s / s.step_s))
            starts = np.flatnonzero(high & ~np.r_[False, high[:-1]])
            ends = np.flatnonzero(high & ~np.r_[high[1:], False])
            for first, last in zip(starts, ends, strict=True):
                columns[name][first : last + after + 1] = np.nan
                effects.append({"voltage": name, "start_utc": str(self.start + pd.Timedelta(seconds=first * s.step_s)),
                                "seconds": float((last - first + 1) * s.step_s)})  # fmt: skip
        return effects

    def _cut_at_anode_changes(self, changes: pd.Series, valid: np.ndarray) -> int:
        """Leave out (in ``valid``) each anode change's step and the next ``anode_change_after_s``; how many."""
        s = self.settings
        if s.anode_change_after_s <= 0:
            return 0
        after = max(int(round(s.anode_change_after_s / s.step_s)), 1)
        first = ((changes - self.start).dt.total_seconds() // s.step_s).astype(int).to_numpy()
        inside = first[(first >= 0) & (first < self.steps)]
        for step in inside:
            valid[step : step + after] = False
        return len(inside)

    @staticmethod
    def _blank_implausible(columns: dict[str, np.ndarray]) -> dict[str, int]:
        blanked = {}
        for name, values in columns.items():
            low, high = PLAUSIBLE_RANGE.get(name, (0.0, np.inf) if name in MASS_STATES else (-np.inf, np.inf))
            outside = np.isfinite(values) & ((values < low) | (values > high) | ((values <= 0) & (name in MASS_STATES)))
            if outside.any():
                values[outside] = np.nan
                blanked[name] = int(outside.sum())
        return blanked

    def _hold(self, columns: dict[str, np.ndarray]) -> dict[str, int]:
        """Hold each logged input's last value across each gap of at most ``max_gap_s`` (a longer gap is
        cut whole); the steps held, per input."""
        limit = int(self.settings.max_gap_s // self.settings.step_s)
        held = {}
        for name in LOGGED_INPUTS:
            if name in columns:
                empty = pd.Series(np.isnan(columns[name]))
                run = empty.groupby((~empty).cumsum()).transform("sum")  # the length of the gap a step is in
                short = (empty & (run <= limit)).to_numpy()
                columns[name] = np.where(short, pd.Series(columns[name]).ffill().to_numpy(), columns[name])
                held[name] = int(np.isfinite(columns[name][short]).sum())
        return held

    def _trajectories(self, valid: np.ndarray) -> tuple[np.ndarray, int]:
        """Each step's trajectory (-1: none) and the steps left over: a stretch between cuts is one
        trajectory, or as many whole ones of ``trajectory_s`` as it holds (equal lengths, as discovery needs)."""
        stretch = np.cumsum(valid & ~np.r_[False, valid[:-1]]) - 1  # a stretch starts after each cut
        if self.settings.trajectory_s is None:
            return np.where(valid, stretch, -1), 0
        length = int(round(self.settings.trajectory_s / self.settings.step_s))
        position = np.arange(len(valid)) - np.maximum.accumulate(
            np.where(valid & ~np.r_[False, valid[:-1]], np.arange(len(valid)), 0)
        )
        piece = np.where(valid, position // length, -1)
        sizes = pd.Series(position[valid]).groupby(stretch[valid]).transform("size").to_numpy()
        whole = np.zeros(len(valid), bool)
        whole[valid] = position[valid] < sizes // length * length
        keys = pd.Series(list(zip(stretch, piece, strict=True)))
        trajectory = np.where(whole, pd.factorize(keys.where(whole))[0], -1)
        return trajectory, int(valid.sum() - whole.sum())

    def _cuts(self, valid: np.ndarray) -> list[dict]:
        """The stretches left out where an input had no value for longer than ``max_gap_s``."""
        s, cuts = self.settings, []
        starts = np.flatnonzero(~valid & np.r_[True, valid[:-1]])
        ends = np.flatnonzero(~valid & np.r_[valid[1:], True])
        for first, last in zip(starts, ends, strict=True):
            cuts.append({"start_utc": str(self.start + pd.Timedelta(seconds=first * s.step_s)),
                         "seconds": float((last - first + 1) * s.step_s)})  # fmt: skip
        return cuts

    def events(self, logged: pd.DataFrame, record: pd.DataFrame) -> tuple[pd.DataFrame, dict]:
        """The events on the record's clock, in the trajectory they fall in (their whole duration),
        in kg; the report's count of each kind placed and left out."""
        s = self.settings
        time_s = (logged["time"] - self.start).dt.total_seconds().to_numpy()
        span = record.groupby("trajectory")["time_s"].agg(["min", "max"])
        trajectory = np.full(len(logged), np.nan)
        for t, (first, last) in span.iterrows():
            inside = (time_s >= first) & (time_s + logged["duration_s"].to_numpy() <= last + s.step_s)
            trajectory[inside & (time_s < last + s.step_s)] = t
        kinds = logged["tag"].map(lambda t: self.tags.events[t].kind)
        amount, weighed = np.empty(len(logged)), np.full(len(logged), np.nan)
        for tag, rows in logged.groupby("tag").indices.items():
            amount[rows] = self.tags.events[tag].kilograms(logged["amount"].to_numpy(float)[rows])
            weighed[rows] = self.tags.events[tag].kilograms(np.asarray(logged["weighed"], float)[rows])
        events = pd.DataFrame({"trajectory": trajectory, "time_s": time_s, "kind": kinds.to_numpy(), "amount_kg": amount,
                               "duration_s": logged["duration_s"].to_numpy(float), "weighed_kg": weighed})  # fmt: skip
        kept = events[np.isfinite(trajectory)].sort_values(["trajectory", "time_s"], kind="stable")
        counts = {
            kind: {"placed": int((kept["kind"] == kind).sum()), "left_out": int(((events["kind"] == kind) & ~np.isfinite(trajectory)).sum())}
            for kind in sorted(set(kinds))
        }  # fmt: skip
        return kept.astype({"trajectory": int}).reset_index(drop=True), counts
