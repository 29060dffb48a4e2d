"""The tag map: which historian tag is which channel, input or event, and in which unit.

A YAML file::

    signals:                          # sampled values, in the export or the lab's file
      POT12.VOLT: {to: U_pot, unit: V}
      LINE.AMPS: {to: u2, unit: kA}
      BATH_TEMP: {to: x6, unit: degF}
      XS_ALF3: {to: c3, unit: percent}
      METAL_HEIGHT: {to: x5, unit: cm}   # a height: cathode_area_m2 makes it a mass
    events:                           # amounts at times, in the events log
      FEEDER_SHOT: {kind: alumina_dose, unit: kg}
      ALF3_ADD: {kind: alf3_addition, unit: kg}
      TAP: {kind: tap, unit: t}
    ignore: [POT12.SETPOINT]          # tags in the export that are none of these
    cathode_area_m2: 12.0             # metal mass = 2300 kg/m3 x area x height
    good_quality: [good, "192"]       # quality codes kept (a long export's fourth column)

Units are pint's (``kA``, ``degF``, ``percent``, ``t``, ``lb``); each converts to the unit of
its target (:data:`costa.variables.UNIT`) or the map is refused naming the tag.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path

import numpy as np
import pint
import yaml

from ..data import TrajectoryDataError
from ..events import EVENT_KINDS
from ..variables import CHANNELS, UNIT

__all__ = ["METAL_DENSITY", "EventTag", "Signal", "TagMap", "read_tag_map"]

METAL_DENSITY = 2300.0  #: molten aluminium [kg/m3]: a metal height times the cathode area and this is x5
KEYS = ("signals", "events", "ignore", "cathode_area_m2", "good_quality")
#: targets a signal may have: the channels the contract measures and the inputs logged as values
TARGETS = tuple(c for c in CHANNELS if c != "m_tap") + ("u2", "u5")


@cache
def units() -> pint.UnitRegistry:
    return pint.UnitRegistry()


def _pint_unit(name: str) -> str:
    """The project's unit as pint spells it."""
    return {"-": "dimensionless", "degC": "degC"}.get(name, name)


@dataclass(frozen=True, kw_only=True)
class Signal:
    """A historian tag measured as values: its ``target`` (a channel or input) and ``unit``."""

    tag: str
    target: str
    unit: str
    cathode_area_m2: float | None = None  # where x5 is logged as a height

    def convert(self, values: np.ndarray) -> np.ndarray:
        """``values`` in the tag's unit, in the target's (:data:`costa.variables.UNIT`)."""
        registry = units()
        if self.cathode_area_m2 is not None:
            metres = registry.Quantity(values, self.unit).to("m").magnitude
            return METAL_DENSITY * self.cathode_area_m2 * metres
        return registry.Quantity(values, self.unit).to(_pint_unit(UNIT[self.target])).magnitude


@dataclass(frozen=True, kw_only=True)
class EventTag:
    """A historian tag logged as amounts at times: its event ``kind`` (:data:`costa.events.EVENT_KINDS`)."""

    tag: str
    kind: str
    unit: str

    def kilograms(self, amounts: np.ndarray) -> np.ndarray:
        return units().Quantity(amounts, self.unit).to("kg").magnitude


@dataclass(frozen=True, kw_only=True)
class TagMap:
    """The checked tag map of one export (read by :func:`read_tag_map`)."""

    path: Path
    signals: dict[str, Signal]
    events: dict[str, EventTag] = field(default_factory=dict)
    ignore: frozenset[str] = frozenset()
    good_quality: frozenset[str] = frozenset({"good"})

    def targets(self) -> set[str]:
        return {s.target for s in self.signals.values()}


def read_tag_map(path: str | Path) -> TagMap:
    """Read and check a tag map: known keys, targets and event kinds, units that convert."""
    path = Path(path)
    if not path.is_file():
        raise TrajectoryDataError(f"{path}: the tag map does not exist")
    raw = yaml.safe_load(path.read_text()) or {}
    if not isinstance(raw, Mapping):
        raise TrajectoryDataError(f"{path}: a tag map is a mapping with keys {list(KEYS)}")
    unknown = sorted(set(raw) - set(KEYS))
    if unknown:
        raise TrajectoryDataError(f"{path}: unknown key(s) {unknown}; a tag map has {list(KEYS)}")
    area = raw.get("cathode_area_m2")
    signals = {tag: _signal(path, str(tag), spec, area) for tag, spec in (raw.get("signals") or {}).items()}
    events = {tag: _event(path, str(tag), spec) for tag, spec in (raw.get("events") or {}).items()}
    both = sorted(set(signals) & set(events))
    if both:
        raise TrajectoryDataError(f"{path}: tag {both[0]!r} is mapped both as a signal and as an event")
    twice = sorted({s.target for s in signals.values() if [t.target for t in signals.values()].count(s.target) > 1})
    if twice:
        tags = [t for t, s in signals.items() if s.target == twice[0]]
        raise TrajectoryDataError(f"{path}: tags {tags} are all mapped to {twice[0]!r}; map one tag a target")
    if "u2" not in {s.target for s in signals.values()}:
        raise TrajectoryDataError(f"{path}: no tag is mapped to u2 (the line current): a pot's record needs it")
    quality = frozenset(str(q).strip().lower() for q in raw.get("good_quality", ["good"]))
    return TagMap(path=path, signals=signals, events=events, ignore=frozenset(map(str, raw.get("ignore") or [])),
                  good_quality=quality)  # fmt: skip


def _signal(path: Path, tag: str, spec, area) -> Signal:
    if not isinstance(spec, Mapping) or set(spec) != {"to", "unit"}:
        raise TrajectoryDataError(f"{path}: signal {tag!r} needs exactly 'to' and 'unit', found {spec!r}")
    target, unit = str(spec["to"]), str(spec["unit"])
    if target not in TARGETS:
        raise TrajectoryDataError(
            f"{path}: signal {tag!r} maps to unknown target {target!r}; known: {', '.join(TARGETS)}"
        )
    height = _dimensionality(path, tag, unit) == units().meter.dimensionality and target == "x5"
    if height and not area:
        raise TrajectoryDataError(
            f"{path}: signal {tag!r} logs x5 (metal mass) as a height in {unit}: give cathode_area_m2 to make it a mass"
        )
    signal = Signal(tag=tag, target=target, unit=unit, cathode_area_m2=float(area) if height else None)
    try:
        signal.convert(np.ones(1))
    except pint.DimensionalityError:
        raise TrajectoryDataError(
            f"{path}: signal {tag!r} in {unit} does not convert to {target}'s unit {UNIT[target]}"
        ) from None
    return signal


def _event(path: Path, tag: str, spec) -> EventTag:
    if not isinstance(spec, Mapping) or set(spec) != {"kind", "unit"}:
        raise TrajectoryDataError(f"{path}: event {tag!r} needs exactly 'kind' and 'unit', found {spec!r}")
    kind, unit = str(spec["kind"]), str(spec["unit"])
    if kind not in EVENT_KINDS:
        raise TrajectoryDataError(f"{path}: event {tag!r} has unknown kind {kind!r}; known: {', '.join(EVENT_KINDS)}")
    event = EventTag(tag=tag, kind=kind, unit=unit)
    _dimensionality(path, tag, unit)
    try:
        event.kilograms(np.ones(1))
    except pint.DimensionalityError:
        raise TrajectoryDataError(f"{path}: event {tag!r} in {unit} is not a mass (kg, t, lb)") from None
    return event


def _dimensionality(path: Path, tag: str, unit: str):
    try:
        return units().Unit(unit).dimensionality
    except (pint.UndefinedUnitError, ValueError, TypeError, AssertionError):
        raise TrajectoryDataError(f"{path}: tag {tag!r} has the unit {unit!r}, which pint does not know") from None
