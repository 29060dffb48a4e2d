"""How often the truth is among the explanations that "what to measure next" separates.

A recommendation's chance of a name (:func:`costa.discover.sparse.measure_next.decides`) holds where one
of the explanations it compares is the truth.  The benchmark knows the truth: per sensor set and
outcome (unexplained, not identifiable) it counts the rounds that recommended a measurement and those
whose explanations held a right name (one the case accepts; a null case's never does), with the Wilson
interval.  A findings page multiplies each chance by this share of its records' kind
(:func:`costa.discover.rates.truth_listed`): the chance of a right name, not of any name.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from ..discover.rates import undecided_outcome
from .score import wilson

__all__ = ["COLUMNS", "listed_rates", "recommending_rounds", "truth_listed_table"]

#: a row of :func:`recommending_rounds`
COLUMNS = ["case", "sensors", "round", "outcome", "listed"]


def recommending_rounds(found: Mapping[str, Any], sensors: str) -> list[dict[str, Any]]:
    """One row per round of a run's findings that recommended a measurement: its outcome and whether a
    name the case accepts is among the explanations its recommendations compare."""
    accepted = set(found.get("accepted", []))
    return [
        {
            "case": found["case"],
            "sensors": sensors,
            "round": r["round"],
            "outcome": undecided_outcome(r["verdict"]),
            "listed": bool(accepted & set(r["measure_next"][0]["explanations"])),
        }
        for r in found["rounds"]
        if r.get("measure_next")
    ]


def listed_rates(rounds: pd.DataFrame) -> pd.DataFrame:
    """Per sensor set and outcome (in the order of ``rounds``, :func:`recommending_rounds` rows): the rounds that
    recommended a measurement, those whose explanations held the truth, the share and its Wilson 95 % interval."""
    columns = ["sensors", "outcome", "rounds", "listed", "share", "share_low", "share_high"]
    rows = []
    for (sensors, outcome), group in rounds.groupby(["sensors", "outcome"], sort=False):
        listed = int(group.listed.sum())
        low, high = wilson(listed, len(group))
        rows.append([sensors, outcome, len(group), listed, listed / len(group), low, high])
    return pd.DataFrame(rows, columns=columns)


def truth_listed_table(findings_paths: Sequence[str | Path], sensors: Sequence[str]) -> pd.DataFrame:
    """:func:`listed_rates` over the runs whose findings are at ``findings_paths``, each under its sensor set."""
    rows = [
        row
        for path, sensor_set in zip(findings_paths, sensors, strict=True)
        for row in recommending_rounds(json.loads(Path(path).read_text()), sensor_set)
    ]
    return listed_rates(pd.DataFrame(rows, columns=COLUMNS))
