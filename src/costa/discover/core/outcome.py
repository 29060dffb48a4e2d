"""What every route's discovery returns: the contract the findings are written from.

A run gives an :class:`Outcome`, whichever route made it: its rounds, the corrected model, the
noise, the gap before and after on the held-out data, and which kind of measurements it searched
(``measured``: "full", every state; "partial", some channels).  A round is a :class:`Round`: the model it started from,
its ranking of fitted candidates, the one chosen (or none), those equivalent to it, whether the
data tell it from them (``identifiable``) and its verdict.  The full-state route
(:mod:`..full_state`) and the sparse routes (:mod:`..sparse`) each build one; :mod:`..findings`
reads nothing else.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import pandas as pd

from ...physics import CellModel

__all__ = ["Outcome", "Round"]


class Round(Protocol):
    model: CellModel
    ranking: Sequence[Any]
    chosen: Any | None
    equivalent: Sequence[Any]
    verdict: str
    identifiable: bool  # False: an explanation of other physics is as good as the chosen one; nothing is named

    @property
    def flagged(self) -> list[str]: ...


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
