"""The named, replaceable parts of the cell model.

A :class:`Part` computes one physical quantity from the cell variables, the
constants and the quantities computed before it (``q``).  The model evaluates its
parts in :data:`PART_ORDER`, so a part may read any part listed before it.
Replacing a part (the ablation g1 = 968 degC, a hidden effect, a discovered
correction) changes every balance that uses it, and nothing else.

Physical reading of the terms (ledge thickness delta = k0 x1 [m], A = k9 [m^2]):

- freezing rate w = k1 (g1 - x7)/(k0 x1) - k2 (x6 - g1) [kg/s]: the heat conducted
  from the freezing front into the ledge minus the heat the bath brings to the
  front, over the fusion enthalpy;
- ``bath_freezing_heat`` = c_p,liq (x6 - g1) w and ``ledge_freezing_heat`` =
  c_p,s (g1 - x7) w [W]: the sensible heat of the mass that freezes, written
  expanded with k7, k8, k12, k13 as the authors' code does.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

from .cell import Array, CellVariables
from .parameters import CellParameters

__all__ = [
    "PART_ORDER",
    "Part",
    "authors_code_parts",
    "constant_part",
    "paper_printed_parts",
]

PartFunction = Callable[[CellVariables, CellParameters, Mapping[str, Array]], Array]


@dataclass(frozen=True)
class Part:
    """One named quantity of the model: ``symbol = formula`` in ``unit``."""

    name: str
    symbol: str
    unit: str
    formula: str
    fn: PartFunction

    def __call__(self, v: CellVariables, k: CellParameters, q: Mapping[str, Array]) -> Array:
        return self.fn(v, k, q)

    def renamed(self, formula: str, fn: PartFunction) -> Part:
        """The same quantity computed another way."""
        return Part(self.name, self.symbol, self.unit, formula, fn)


# --------------------------------------------------------------------------- bath
def _liquidus(v, k, q):
    p2, p3 = v.p2, v.p3
    return (
        991.2
        + 1.12 * p3
        - 0.13 * p3**2.2
        + 0.061 * p3**1.5
        - 7.93 * p2 / (1 + 0.0936 * p3 - 0.0017 * p3**2 - 0.0023 * p3 * p2)
    )


def _conductivity(v, k, q):
    return v.xp.exp(2.496 - 2068.4 / (273 + v.x6) - 2.07 * v.c2)


def _current_polynomial(i, linear):
    return 0.531 + linear * i - 2.51e-12 * i**2 + 3.06e-18 * i**3


def _alumina_fraction_term(v, k):
    d = v.p2 - k.critical_alumina_percent
    return (0.431 - 0.1437 * d) / (1 + 7.353 * d)


def _bubble_coverage(v, k, q):
    return _current_polynomial(v.u2, 6.958e-7) + _alumina_fraction_term(v, k)


def _bubble_coverage_printed(v, k, q):
    return _current_polynomial(v.u1, 6.96e-7) + _alumina_fraction_term(v, k)


def _bubble_thickness(v, k, q):
    return (0.5517 + 3.8168e-6 * v.u2) / (1 + 8.271e-6 * v.u2)


def _bubble_voltage(v, k, q):
    g3 = q["bubble_coverage"]
    return 3.8168e-6 * g3 * q["bubble_thickness"] * v.u2 / (q["bath_conductivity"] * (1 - g3))


def _cell_voltage(v, k, q):
    return q["bubble_voltage"] + v.u2 * v.u5 / (2620 * q["bath_conductivity"])


def _electric_power(v, k, q):
    return v.u2 * q["cell_voltage"]


# -------------------------------------------------------------- ledge and heat
def _freezing_rate(v, k, q):
    g1 = q["liquidus_temperature"]
    return k.k1 * (g1 - v.x7) / (k.k0 * v.x1) - k.k2 * (v.x6 - g1)


def _bath_ledge_heat(v, k, q):
    return k.k9 * (v.x6 - v.x7) / (k.k10 + k.k11 * k.k0 * v.x1)


def _front_ledge_heat(v, k, q):
    return k.k9 * (q["liquidus_temperature"] - v.x7) / (k.k15 * k.k0 * v.x1)


def _ledge_wall_heat(v, k, q):
    return k.k9 * (v.x7 - v.x8) / (k.k14 + k.k15 * k.k0 * v.x1)


def _wall_ambient_heat(v, k, q):
    return k.k9 * (v.x8 - k.k16) / (k.k14 + k.k18)


def _bath_freezing_heat(v, k, q):
    g1 = q["liquidus_temperature"]
    return k.k8 * (v.x6 - g1) * (g1 - v.x7) / (k.k0 * v.x1) - k.k7 * (v.x6 - g1) ** 2


def _ledge_freezing_heat(v, k, q):
    g1 = q["liquidus_temperature"]
    return k.k13 * (g1 - v.x7) ** 2 / (k.k0 * v.x1) - k.k12 * (v.x6 - g1) * (g1 - v.x7)


# --------------------------------------------------------------- mass flows
def _alumina_consumption(v, k, q):
    return k.k3 * v.u2


def _alf3_neutralisation(v, k, q):
    return k.k4 * v.u1


def _cryolite_formation(v, k, q):
    return k.k5 * v.u1


def _metal_production(v, k, q):
    return k.k6 * v.u2


_G1 = "991.2 + 1.12 p3 - 0.13 p3^2.2 + 0.061 p3^1.5 - 7.93 p2 / (1 + 0.0936 p3 - 0.0017 p3^2 - 0.0023 p3 p2)"
_G3_TAIL = " + (0.431 - 0.1437 (p2 - 2.2)) / (1 + 7.353 (p2 - 2.2))"

_CODE_PARTS = (
    Part("liquidus_temperature", "g1", "degC", _G1, _liquidus),
    Part("bath_conductivity", "g2", "S/cm", "exp(2.496 - 2068.4/(273 + x6) - 2.07 c2)", _conductivity),
    Part(
        "bubble_coverage",
        "g3",
        "-",
        "0.531 + 6.958e-7 u2 - 2.51e-12 u2^2 + 3.06e-18 u2^3" + _G3_TAIL,
        _bubble_coverage,
    ),  # fmt: skip
    Part("bubble_thickness", "g4", "cm", "(0.5517 + 3.8168e-6 u2) / (1 + 8.271e-6 u2)", _bubble_thickness),
    Part("bubble_voltage", "g5", "V", "3.8168e-6 g3 g4 u2 / (g2 (1 - g3))", _bubble_voltage),
    Part("cell_voltage", "U", "V", "g5 + u2 u5 / (2620 g2)", _cell_voltage),
    Part("electric_power", "P_el", "W", "u2 U", _electric_power),
    Part("freezing_rate", "w", "kg/s", "k1 (g1 - x7)/(k0 x1) - k2 (x6 - g1)", _freezing_rate),
    Part("bath_ledge_heat", "Q_bath_ledge", "W", "k9 (x6 - x7)/(k10 + k11 k0 x1)", _bath_ledge_heat),
    Part("front_ledge_heat", "Q_front_ledge", "W", "k9 (g1 - x7)/(k15 k0 x1)", _front_ledge_heat),
    Part("ledge_wall_heat", "Q_ledge_wall", "W", "k9 (x7 - x8)/(k14 + k15 k0 x1)", _ledge_wall_heat),
    Part("wall_ambient_heat", "Q_wall_ambient", "W", "k9 (x8 - k16)/(k14 + k18)", _wall_ambient_heat),
    Part(
        "bath_freezing_heat",
        "Q_bath_freeze",
        "W",
        "k8 (x6 - g1)(g1 - x7)/(k0 x1) - k7 (x6 - g1)^2",
        _bath_freezing_heat,
    ),  # fmt: skip
    Part(
        "ledge_freezing_heat",
        "Q_ledge_freeze",
        "W",
        "k13 (g1 - x7)^2/(k0 x1) - k12 (x6 - g1)(g1 - x7)",
        _ledge_freezing_heat,
    ),  # fmt: skip
    Part("alumina_consumption", "r_Al2O3", "kg/s", "k3 u2", _alumina_consumption),
    Part("alf3_neutralisation", "r_AlF3", "kg/s", "k4 u1", _alf3_neutralisation),
    Part("cryolite_formation", "r_cry", "kg/s", "k5 u1", _cryolite_formation),
    Part("metal_production", "r_Al", "kg/s", "k6 u2", _metal_production),
)

PART_ORDER: tuple[str, ...] = tuple(p.name for p in _CODE_PARTS)


def authors_code_parts() -> dict[str, Part]:
    """The parts of the true model as the authors' simulator codes them."""
    return {p.name: p for p in _CODE_PARTS}


def paper_printed_parts() -> dict[str, Part]:
    """The parts as printed: g3 reads the alumina feed u1 (and 6.96e-7), not the current."""
    parts = authors_code_parts()
    parts["bubble_coverage"] = parts["bubble_coverage"].renamed(
        "0.531 + 6.96e-7 u1 - 2.51e-12 u1^2 + 3.06e-18 u1^3" + _G3_TAIL,
        _bubble_coverage_printed,
    )
    return parts


def constant_part(part: Part, value: float) -> Part:
    """``part`` fixed at a constant (the ablation g1 = 968 degC is one)."""

    def fn(v, k, q):
        return v.xp.full_like(v.x1, value)

    return part.renamed(f"{value:g}", fn)
