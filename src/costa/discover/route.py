"""Which route decides a record, chosen once from what it samples and how often.

- **full state**: every state x1..x8 at every step (weak-form equation tests, :mod:`.full_state`);
- **filter**: the composition (c2 and c3) logged, no hand samples, or hand samples rarer than one
  a shift (a pot line's daily samples): the augmented filter and smoother (:mod:`.sparse.filter`);
- **shooting**: hand samples (bath temperature, AlF3, metal) every shift or more often and the
  composition not logged: the first round by multiple shooting on the first
  :data:`SHOOTING_CELLS` cells (:mod:`.sparse.shooting`).

The workflow asks :func:`choose_route` with a sensor set's declared intervals, the discovery run
with the record's own (:func:`record_route`, the mean time between samples); a stated
``shooting_cells`` overrides the number of cells (0: the filter).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ..sensors import LOGGED_S
from ..variables import STATES

__all__ = ["LOGGED_S", "SHIFT_S", "SHOOTING_CELLS", "Route", "choose_route", "record_route"]

SHIFT_S = 8 * 3600.0  #: a shift [s]: hand samples at least this often are fitted by multiple shooting
SHOOTING_CELLS = 2  #: cells the shooting round fits where the record does not say (the plant cases: 2-3 min)
COMPOSITION = ("c2", "c3")


@dataclass(frozen=True, kw_only=True)
class Route:
    """The route ``name`` ("full_state", "filter" or "shooting"), the cells a shooting round fits
    (0 on the other routes), ``why``, one phrase for the log, and ``records``: the benchmark's sensor
    set whose records are sampled alike (every state: "full"; the composition logged, or no hand
    samples: "partial"; hand samples every shift or more often: "plant"; rarer: "pot_line"), whose
    rates a findings page quotes."""

    name: str
    shooting_cells: int = 0
    why: str
    records: str


def choose_route(intervals: Mapping[str, float], *, dt_s: float, shooting_cells: int | None = None) -> Route:
    """The route of a record whose channels are sampled every ``intervals[channel]`` seconds (NaN: at
    most once a trajectory; events such as taps left out) at step ``dt_s`` [s]; ``shooting_cells``:
    the cells a shooting round fits, as stated (None: :data:`SHOOTING_CELLS` where the samples call
    for it; 0: never).  A channel sampled at least every :data:`LOGGED_S` is logged, any other
    state or composition channel hand-sampled."""
    if all(intervals.get(s) == dt_s for s in STATES):
        return Route(name="full_state", why="every state at every step", records="full")
    logged = {c for c, every in intervals.items() if every <= LOGGED_S}
    hand = [intervals[c] for c in (*STATES, *COMPOSITION) if c in intervals and c not in logged]
    rare = not all(np.isfinite(hand)) or max(hand, default=0.0) > SHIFT_S
    records = "partial" if logged.issuperset(COMPOSITION) or not hand else "pot_line" if rare else "plant"
    if logged.issuperset(COMPOSITION):
        return Route(name="filter", why="the composition logged", records=records)
    if shooting_cells == 0:
        return Route(name="filter", why="shooting_cells: 0", records=records)
    if shooting_cells is not None:
        why = f"shooting_cells: {shooting_cells}"
        return Route(name="shooting", shooting_cells=shooting_cells, why=why, records=records)
    if not hand:
        return Route(name="filter", why="no hand samples", records=records)
    if rare:
        return Route(name="filter", why="hand samples rarer than one a shift (8 h)", records=records)
    why = "hand samples every shift (8 h) or more often"
    return Route(name="shooting", shooting_cells=SHOOTING_CELLS, why=why, records=records)


def record_route(tables: list[pd.DataFrame], dt_s: float, shooting_cells: int | None = None) -> Route:
    """:func:`choose_route` on what the ``tables`` (the training and held-out trajectories) measure:
    each channel at the mean time between its samples within a trajectory, the sparser of the tables
    (``dt_s`` only where sampled at every step of every table)."""
    intervals: dict[str, float] = {}
    for table in tables:
        for channel in set(table.columns) & {*STATES, *COMPOSITION, "U_cell", "U_pot"}:
            sampled = table[["trajectory", "time_s"]][table[channel].notna()]
            if sampled.empty:
                continue
            spans = sampled.groupby("trajectory")["time_s"].agg(["min", "max", "size"])
            gaps = int((spans["size"] - 1).sum())
            every = (
                dt_s if len(sampled) == len(table) else (spans["max"] - spans["min"]).sum() / gaps if gaps else np.nan
            )
            intervals[channel] = float(np.maximum(intervals.get(channel, every), every))  # NaN stays
    return choose_route(intervals, dt_s=dt_s, shooting_cells=shooting_cells)
