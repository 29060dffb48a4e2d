"""What every route's discovery returns: the contract the findings are written from.

A run gives an :class:`Outcome`, whichever route made it: its rounds, the corrected model, the
noise, the gap before and after on the held-out data, and which kind of measurements it searched
(``measured``: "full", every state; "partial", some channels).  A round is a :class:`Round`: the
model it started from, its tests, its ranking of fitted candidates, the one chosen (or none),
those equivalent to it, its :class:`Decision` (by :func:`.naming.conclude`, the rule every route
follows) and its verdict in words.  What it names, whether the data tell it from the others and
whether its form is incomplete follow from the decision alone, here.  The full-state route
(:mod:`..full_state`) and the sparse routes (:mod:`..sparse`) each build one; :mod:`..findings`
reads nothing else.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from ...physics import CellModel
from .hypotheses import Hypothesis

__all__ = ["Decision", "Outcome", "Round", "compared_models"]


class Decision(enum.Enum):
    """What a round concludes (:func:`.naming.conclude`)."""

    QUIET = "quiet"  # nothing disagrees beyond noise: nothing to explain
    UNEXPLAINED = "unexplained"  # no correction explains the disagreement
    NOT_IDENTIFIABLE = "not identifiable"  # the best correction is applied, nothing is named
    NAMED = "named"
    FORM_INCOMPLETE = "form incomplete"  # named, its closed form leaving a small error beyond noise


@dataclass(kw_only=True)
class Round:
    """What one round found, on any route: ``tests`` of the equations or measured channels,
    ``ranking`` the fitted candidates (best first), ``chosen`` the correction applied (or None),
    ``equivalent`` those the data do not tell from it (its rivals too, where undecided); ``name``: what
    the chosen correction is named as where that is not its own hypothesis (the flow missing from the
    one balance it moves); ``rich``: its candidates were fitted with the richer term library (a full-state
    round after the first; a sparse round the basic library left unexplained)."""

    model: CellModel
    tests: list
    ranking: list
    chosen: Any | None
    equivalent: list
    verdict: str
    decision: Decision
    name: Hypothesis | None = None
    rich: bool = False

    @property
    def identifiable(self) -> bool:
        """False where an explanation of other physics is as good as the chosen one: nothing is named."""
        return self.decision is not Decision.NOT_IDENTIFIABLE

    @property
    def named(self) -> Hypothesis | None:
        """What the round names: the chosen explanation (or ``name``) where its decision names one."""
        if self.decision not in (Decision.NAMED, Decision.FORM_INCOMPLETE) or self.chosen is None:
            return None
        return self.name or self.chosen.hypothesis

    @property
    def form_incomplete(self) -> bool:
        """Named although its closed form leaves channels disagreeing (it removes nearly all of their excess)."""
        return self.decision is Decision.FORM_INCOMPLETE

    @property
    def corrected(self) -> CellModel | None:
        return self.chosen.corrected if self.chosen is not None else None


@dataclass(kw_only=True)
class Outcome:
    """What a run found, on any route: ``noise`` per state ("full") or per measured channel
    (``channels``, "partial"); ``gap``, ``per_state`` (per state or channel) and ``floor`` on the
    held-out data in ``windows`` [start, stop) of its steps of ``dt`` s."""

    measured: str  # "full" (every state) or "partial" (some channels, possibly sparse)
    rounds: Sequence[Round]
    noise: np.ndarray
    corrected: CellModel
    gap: pd.DataFrame
    per_state: pd.DataFrame
    floor: Mapping[str, float]
    seconds: float
    windows: Mapping[str, tuple[int, int]]
    dt: float
    constant_inputs: tuple[str, ...] = ()  # inputs that did not vary in the training data
    channels: tuple[str, ...] = ()  # partial: the measured channels
    start_steps: int = 0  # partial: the first samples of each held-out cell, which place its first state
    restart_steps: int | None = None  # partial: the gap's forecasts restarted every this many steps
    records: str = "full"  # the benchmark's sensor set sampled as these data are (:attr:`..route.Route.records`)


def compared_models(rounds: Sequence[Round], start: CellModel) -> dict[str, CellModel]:
    """The models the gap compares: the starting model and, where a round applied a correction, the
    last one applied ("corrected model")."""
    corrected = next((r.corrected for r in reversed(rounds) if r.corrected is not None), start)
    return {"starting model": start} | ({"corrected model": corrected} if corrected is not start else {})
