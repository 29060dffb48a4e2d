"""Names, meanings and units of the cell's states, inputs and derived quantities.

States are x1..x8 and inputs u1..u5 as in the paper (array index = number - 1).
A measured table may also carry the model's outputs: the cell voltage ``U_cell``
(the bath's and bubbles' part), the pot voltage ``U_pot`` (what a pot line logs),
the bath's Al2O3 and AlF3 mass fractions ``c2``, ``c3`` and the metal a tap removed as
the crane scale weighs it, ``m_tap`` (per second of the tap, at its first step).  States and outputs are the
measurement *channels*; ``g1`` (the simulator's true liquidus temperature) is kept in
simulated tables for reference only.
"""

from __future__ import annotations

STATES: tuple[str, ...] = tuple(f"x{i}" for i in range(1, 9))
INPUTS: tuple[str, ...] = tuple(f"u{i}" for i in range(1, 6))
OUTPUTS: tuple[str, ...] = ("U_cell", "U_pot", "c2", "c3", "m_tap")
CHANNELS: tuple[str, ...] = (*STATES, *OUTPUTS)
AUXILIARY: tuple[str, ...] = ("g1",)

MEANING: dict[str, str] = {
    "x1": "side-ledge mass",
    "x2": "Al2O3 mass",
    "x3": "AlF3 mass",
    "x4": "molten cryolite mass",
    "x5": "metal mass",
    "x6": "bath temperature",
    "x7": "side-ledge temperature",
    "x8": "wall temperature",
    "u1": "Al2O3 feed",
    "u2": "line current",
    "u3": "AlF3 feed",
    "u4": "metal tapping",
    "u5": "anode-cathode distance",
    "g1": "liquidus temperature",
    "U_cell": "cell voltage",
    "U_pot": "pot voltage",
    "c2": "Al2O3 mass fraction of the bath",
    "c3": "AlF3 mass fraction of the bath",
    "m_tap": "metal tapped, as weighed",
    "time_s": "time",
}

UNIT: dict[str, str] = {
    "x1": "kg",
    "x2": "kg",
    "x3": "kg",
    "x4": "kg",
    "x5": "kg",
    "x6": "degC",
    "x7": "degC",
    "x8": "degC",
    "u1": "kg/s",
    "u2": "A",
    "u3": "kg/s",
    "u4": "kg/s",
    "u5": "m",
    "g1": "degC",
    "U_cell": "V",
    "U_pot": "V",
    "c2": "-",
    "c3": "-",
    "m_tap": "kg/s",
    "time_s": "s",
}

MASS_STATES: tuple[str, ...] = ("x1", "x2", "x3", "x4", "x5")

#: channel -> (low, high): a sample outside is a logging or unit error.  A pot reads 4-4.6 V; below
#: 2.5 V it makes no metal (its back EMF alone is 1.5-1.9 V), above 7 V it is in an anode effect
#: (8-50 V for minutes), which the model does not describe: leave such samples empty.
PLAUSIBLE_RANGE: dict[str, tuple[float, float]] = {"U_pot": (2.5, 7.0)}


def label(name: str) -> str:
    """Axis label such as ``'x6 bath temperature [degC]'``."""
    return f"{name} {MEANING[name]} [{UNIT[name]}]"
