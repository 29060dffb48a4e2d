"""What is hidden in each case, machine-readable: for scoring a method's answer, never for choosing it.

A :class:`Truth` says which variables the effect depends on and, where the true
correction is (exactly, or to first order at the library's nominal point) a sum of
library terms (:mod:`..core.library`), their coefficients, per representation: the key of
the hypothesis whose correction it is (``term:bath_energy``: a flow in W;
``property:wall_conductivity``: a relative change).  A method's coefficient has a
counterpart only when it corrects in the same representation.  Which equations the
effect changes is not listed: it is computed from the true and starting models
(:func:`changed_equations`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ...physics import CellModel
from ...variables import STATES

__all__ = ["TRUTHS", "Truth", "changed_equations", "correction_variables", "term_variables"]


@dataclass(frozen=True)
class Truth:
    """``variables``: what the effect depends on (None: nothing to check, e.g. a constant
    factor); ``also``: what an equivalent flow form of it legitimately reads besides
    (None: anything); ``coefficients``: representation -> term -> true value;
    ``first_order``: the coefficients are a first-order expansion of a nonlinear effect."""

    variables: frozenset[str] | None
    also: frozenset[str] | None = frozenset()
    coefficients: Mapping[str, Mapping[str, float]] = field(default_factory=dict)
    first_order: bool = False


def _v(*names: str) -> frozenset[str]:
    return frozenset(names)


_TOP_LOSS = {"1": -20570.0, "(x6 - 970)": -22.0}  # -22 (x6 - 35) = -20570 - 22 (x6 - 970) W
_FEED = ("u1", "u3")

TRUTHS: dict[str, Truth] = {
    # g1(c2, c3) at c2 = 0.03, c3 = 0.11: 966.725 degC (PBM: 968), gradient -473.36, -327.47 degC per unit fraction;
    # g1 enters the freezing rate and the heat flows with x6, x7 and x1
    "paper_liquidus": Truth(
        variables=_v("c2", "c3"), also=None,
        coefficients={"part:liquidus_temperature": {"1": -1.2745, "(c2 - 0.03)": -473.36, "(c3 - 0.11)": -327.47}}, first_order=True,
    ),
    "top_heat_loss": Truth(
        variables=_v("x6"), also=frozenset(),
        coefficients={"term:bath_energy": _TOP_LOSS, "part:electric_power": _TOP_LOSS,
         "part:bath_ledge_heat": {k: -v for k, v in _TOP_LOSS.items()}},
    ),
    # 0.02 c3 exp((x6 - 970)/25) ~ 0.0022 + 0.02 (c3 - 0.11) + 0.000088 (x6 - 970) kg/s lost
    "alf3_evaporation": Truth(
        variables=_v("c3", "x6"), also=_v("c2", "m"),
        coefficients={"term:alf3_mass": {"1": -0.0022, "(c3 - 0.11)": -0.02, "(x6 - 970)": -8.8e-5}}, first_order=True,
    ),
    # the wall's resistance is in the ledge-to-wall and wall-to-ambient flows (x7, x8, x1)
    "wall_conductivity": Truth(variables=_v("x8"), also=_v("x7", "x1"), coefficients={"property:wall_conductivity": {"(x8 - 580)": 0.004}}),
    "alumina_dissolution": Truth(
        variables=_v("u1", "superheat"), also=_v("x6", "c2", "c3"),
        coefficients={"term:alumina_mass": {"u1": -0.3, "u1*superheat": 0.015}},
    ),
    # g2 exp(-3.5 (c3 - 0.11)) ~ g2 (1 - 3.5 (c3 - 0.11)); the bath's resistance heats with the current squared
    "conductivity_alf3": Truth(
        variables=_v("c3"), also=_v("u2", "u5", "c2", "x6", "m"), coefficients={"part:bath_conductivity": {"own*(c3 - 0.11)": -3.5}}, first_order=True
    ),
    # 8 % of the feed's command does not arrive: -0.08 u1 kg/s of alumina, and its impurities' share elsewhere
    "alumina_feeder": Truth(variables=_v("u1"), also=frozenset(), coefficients={"input:u1": {"1": -0.08}, "term:alumina_mass": {"u1": -0.08}}),
    # 10 % of the logged tapping stays in the cell: +0.1 u4 kg/s of metal
    "tapping_shortfall": Truth(variables=_v("u4"), also=frozenset(), coefficients={"input:u4": {"1": -0.1}, "term:metal_mass": {"u4": 0.1}}),
    "no_effect": Truth(frozenset(), frozenset()),
    "printed_k4": Truth(variables=_v("u1"), also=frozenset(), coefficients={"term:alf3_mass": {"u1": -0.016},
                                               "part:alf3_neutralisation": {"u1": 0.016}}),
    # a heat capacity scales the whole net flow into the bath: every variable may appear in a flow form
    "bath_heat_capacity": Truth(variables=None, also=None, coefficients={"property:bath_heat_capacity": {"1": 0.1111}}),
    # the efficiency scales the current's production and consumption (u2)
    "current_efficiency": Truth(
        variables=_v("x6"), also=_v("u2"), coefficients={"property:current_efficiency": {"(x6 - 970)": -0.005}}
    ),
    # the ledge's resistance is in every heat flow through it and in the freezing rate
    "ledge_conductivity": Truth(
        variables=_v("x7"), also=None, coefficients={"property:ledge_conductivity": {"(x7 - 820)": -0.002}}
    ),
}  # fmt: skip

#: variables of the term library, as they appear in its term names
_VARIABLES = ("superheat", "c2", "c3", "x6", "x7", "x8", "x1", "m", "u1", "u2", "u3", "u4", "u5")


def term_variables(term: str) -> frozenset[str]:
    """The library variables a term name reads (``own`` is the corrected part itself, not a variable)."""
    names = set()
    for token in term.replace("(", " ").replace(")", " ").replace("*", " ").replace("^", " ").split():
        if token in _VARIABLES:
            names.add(token)
    return frozenset(names)


def correction_variables(representation: str, term: str) -> frozenset[str]:
    """What a fitted term of a correction reads: the term's variables, and the input itself for a
    gain on an input (``input:u1``'s constant term -0.08 is the flow -0.08 u1)."""
    kind, _, target = representation.partition(":")
    return term_variables(term) | (frozenset({target}) if kind == "input" else frozenset())


def changed_equations(model: CellModel, start: CellModel, x: np.ndarray, u: np.ndarray) -> tuple[str, ...]:
    """The states whose rate differs between two models anywhere on samples x (..., 8), u (..., 5)."""
    with np.errstate(all="ignore"):
        a, b = model.rhs(x, u), start.rhs(x, u)
    scale = np.nanmax(np.abs(b).reshape(-1, 8), axis=0) + 1e-300
    differs = np.nanmax(np.abs(a - b).reshape(-1, 8), axis=0) > 1e-9 * scale
    return tuple(s for s, d in zip(STATES, differs, strict=True) if d)
