"""What a model predicts for each measurement channel of the data contract (:mod:`costa.data`).

A state channel x1..x8 is the state itself; ``U_cell`` is the model's cell voltage U
(the part ``cell_voltage``, V: bubbles and the bath's ohmic drop); ``U_pot`` is the
voltage a pot line logs, U + E0 + R_ext u2 [V] with the cell's back EMF E0 and the
resistance R_ext of its anodes, cathode and bus bars at the logged line current u2;
``c2`` and ``c3`` are the bath's Al2O3 and AlF3 mass fractions x2/m and x3/m with
m = x2 + x3 + x4; ``m_tap`` [kg/s] is the tapping rate that reaches the cell, u4 as
delivered (a crane scale's weight of a tap over its duration, :mod:`costa.sensors`).
A model with a corrected voltage part predicts its corrected voltage, one with a
corrected tapping its delivered tapping.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .physics import CellModel, CellVariables
from .variables import CHANNELS, INPUTS, STATES

__all__ = ["SENSED_PART", "observe"]

#: the one part a sensor reads: the voltages (U_cell, U_pot) are computed from it
SENSED_PART = "cell_voltage"


def observe(model: CellModel, x: np.ndarray, u: np.ndarray, channels: Sequence[str]) -> np.ndarray:
    """The channels' values (..., C) at states x (..., 8) and inputs u (..., 5), in the data's units."""
    unknown = [c for c in channels if c not in CHANNELS]
    if unknown:
        raise ValueError(f"unknown channel(s) {unknown}; known: {list(CHANNELS)}")
    v = CellVariables(x, u)
    derived = {"c2": v.c2, "c3": v.c3}
    if "m_tap" in channels:
        derived["m_tap"] = model.delivered_inputs(x, u)[..., INPUTS.index("u4")]
    if {"U_cell", "U_pot"} & set(channels):
        derived["U_cell"] = model.quantities(x, u)[SENSED_PART]
        derived["U_pot"] = derived["U_cell"] + model.params.E0 + model.params.R_ext * v.u2
    return v.xp.stack([x[..., STATES.index(c)] if c in STATES else derived[c] for c in channels], axis=-1)
