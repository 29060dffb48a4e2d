"""Candidate terms for a closed-form correction, in the model's own variables.

Every feature is a readable expression of physical variables, centred at a nominal
operating point so that coefficients are interpretable (``(x6 - 970)`` is the bath
temperature's deviation from 970 degC).  A correction is sum_k xi_k theta_k, with
xi_k in the unit of what it corrects: degC for the liquidus temperature, W for a
heat flow, kg/s for a mass flow.  For a part, "relative" features multiply by the
part's own value (``own * (c3 - 0.11)``: the part changes in proportion to itself),
which is how a coefficient that depends on a state shows up.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from itertools import combinations_with_replacement, product

import numpy as np

from ...physics import CellVariables
from ...variables import INPUTS

__all__ = [
    "FIRST_ORDER",
    "FLOW_INPUTS",
    "LINE_CURRENT",
    "LEDGE_AND_WALL",
    "Feature",
    "constant_inputs",
    "feature_library",
]


@dataclass(frozen=True)
class Feature:
    """theta(v, q, own): a named candidate term; ``own`` is the corrected part's value (parts only).

    ``needs`` names the model quantities it reads, so that a part's correction never
    reads the part itself or a part computed after it.
    """

    name: str
    fn: Callable
    needs: frozenset[str] = frozenset()

    @property
    def reads_flow_inputs(self) -> bool:
        return any(f"{u}*" in self.name or self.name.endswith(u) for u in FLOW_INPUTS)

    def __call__(self, v: CellVariables, q, own):
        return self.fn(v, q, own)


#: variables read from the model's quantities rather than the states and inputs
_NEEDS = {"superheat": frozenset({"liquidus_temperature"})}
#: the feed and tapping flows: a correction of a flow may depend on them, a material
#: property (a liquidus temperature, a conductivity) may not
FLOW_INPUTS = ("u1", "u3", "u4")
#: name -> its nominal value: terms are written in its deviation from it (a name of the cell
#: variables, or the superheat x6 - g1, read from the quantities)
_NOMINAL = {
    "c2": 0.03, "c3": 0.11, "x6": 970.0, "x7": 820.0, "x8": 580.0, "x1": 3000.0, "m": 16000.0, "u2": 140000.0,
    "u5": 0.05, "u1": 0.0, "u3": 0.0, "u4": 0.0, "superheat": 0.0,
}  # fmt: skip
#: squares, and products of the bath's state variables with each other and with the
#: flow drivers (an efficiency that varies multiplies a flow by a function of conditions)
_SQUARED = ("c2", "c3", "x6", "u2")
_STATE_PRODUCTS = (("c2", "c3"), ("c2", "x6"), ("c3", "x6"))
_DRIVERS = ("u1", "u2", "u3")
_CONDITIONS = ("c2", "c3", "x6", "superheat")


def _centred(name: str) -> tuple[str, Callable]:
    """A variable's label and its deviation from its nominal value, read from the cell variables v and quantities q."""
    nominal = _NOMINAL[name]
    label = name if nominal == 0 else f"({name} - {nominal:g})"
    if name == "superheat":
        return label, lambda v, q: v.x6 - q["liquidus_temperature"] - nominal
    return label, lambda v, q: getattr(v, name) - nominal


#: a constant and the bath's composition and temperature, linear: the first-order closed form of a
#: rate, which the measured channels weigh beside the terms a regression selected (a selected proxy
#: such as the superheat, itself a function of them, is then kept only where the channels need it)
FIRST_ORDER = ("1", *(_centred(name)[0] for name in ("c2", "c3", "x6")))
#: the line current, linear in its deviation from its nominal value: it varies by a quarter on a pot line
LINE_CURRENT = _centred("u2")[0]
#: the ledge's and the wall's temperatures, linear: a rate may depend on them as much as on the bath's
#: (the cells of a pot line differ in them)
LEDGE_AND_WALL = tuple(_centred(name)[0] for name in ("x7", "x8"))


#: variables whose squares and pairwise products form the richer library of later rounds
_RICH = ("c2", "c3", "x6", "x7", "x8", "x1", "m", "u2", "u5", "superheat")


def feature_library(relative: bool, rich: bool = False) -> list[Feature]:
    """The candidate terms: constant, linear, squares, products of state variables and of
    flow drivers with conditions, and (``relative``) the constant and linear terms times
    the part's own value.  ``rich`` adds every square and pairwise product of the main
    variables (and, relative, those times the part's own value): for a later round, when
    a simpler closed form left the same equations disagreeing."""
    linear = {name: _centred(name) for name in _NOMINAL}
    needs = {name: _NEEDS.get(name, frozenset()) for name in _NOMINAL}
    features = [Feature("1", lambda v, q, own: v.xp.ones_like(v.x1))]
    features += [
        Feature(name=label, fn=lambda v, q, own, f=f: f(v, q), needs=needs[name]) for name, (label, f) in linear.items()
    ]
    for name in _SQUARED:
        label, f = linear[name]
        features.append(Feature(name=f"{label}^2", fn=lambda v, q, own, f=f: f(v, q) ** 2, needs=needs[name]))
    for a, b in [*_STATE_PRODUCTS, *product(_DRIVERS, _CONDITIONS)]:
        (la, fa), (lb, fb) = linear[a], linear[b]
        features.append(
            Feature(
                name=f"{la}*{lb}", fn=lambda v, q, own, fa=fa, fb=fb: fa(v, q) * fb(v, q), needs=needs[a] | needs[b]
            )
        )
    if relative:
        features.append(Feature("own", lambda v, q, own: own))
        features += [
            Feature(name=f"own*{label}", fn=lambda v, q, own, f=f: own * f(v, q), needs=needs[name])
            for name, (label, f) in linear.items()
        ]
    if rich:
        names = {f.name for f in features}
        for a, b in combinations_with_replacement(_RICH, 2):
            (la, fa), (lb, fb) = linear[a], linear[b]
            label = f"{la}^2" if a == b else f"{la}*{lb}"
            need = needs[a] | needs[b]
            if label not in names:
                features.append(Feature(name=label, fn=lambda v, q, own, fa=fa, fb=fb: fa(v, q) * fb(v, q), needs=need))
            if relative:
                features.append(
                    Feature(
                        name=f"own*{label}", fn=lambda v, q, own, fa=fa, fb=fb: own * fa(v, q) * fb(v, q), needs=need
                    )
                )
    return features


def evaluate(features: list[Feature], v: CellVariables, q, own) -> np.ndarray:
    """All features at once (..., P)."""
    return np.stack([np.broadcast_to(np.asarray(f(v, q, own), dtype=float), v.x1.shape) for f in features], axis=-1)


def constant_inputs(u: np.ndarray) -> tuple[str, ...]:
    """The inputs that do not vary over a record's inputs u (..., 5) (a pot line's line current,
    a record without a tap): their terms duplicate the constant term, so the fits drop them
    (:func:`.regression.independent_columns`), and an effect that reads one cannot be told from a
    constant effect."""
    return tuple(name for i, name in enumerate(INPUTS) if np.ptp(u[..., i]) == 0)
