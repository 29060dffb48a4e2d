"""Physical properties shared by several constants, and corrections that change them.

The model's constants are derived from a few physical properties (docs/model.md §2;
:func:`costa.physics.parameters.authors_code_parameters`): the ledge conductivity
k_sl enters k1, k8 and k13 in proportion and k11, k15 inversely, the current
efficiency enters both the alumina consumption k3 and the metal production k6, and
so on.  A :class:`PropertyCorrection` changes one property by a relative amount
delta(x, u), which rescales every constant it enters by (1 + delta)^exponent.  This
is how "a coefficient that depends on a state" is expressed when the coefficient is
shared by several parts of the model.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

from .cell import Array, CellVariables

__all__ = ["PROPERTIES", "PhysicalProperty", "PropertyCorrection"]


@dataclass(frozen=True)
class PhysicalProperty:
    """A physical property and the exponent with which each model constant depends on it."""

    name: str
    meaning: str
    exponents: Mapping[str, float]


@dataclass(frozen=True)
class PropertyCorrection:
    """property -> property (1 + fn(v)); ``fn`` reads states and inputs only."""

    property: PhysicalProperty
    formula: str
    fn: Callable[[CellVariables], Array]


PROPERTIES: dict[str, PhysicalProperty] = {
    p.name: p
    for p in (
        PhysicalProperty("ledge_conductivity", "thermal conductivity of the side ledge k_sl",
                         {"k1": 1, "k8": 1, "k13": 1, "k11": -1, "k15": -1}),
        PhysicalProperty("wall_conductivity", "thermal conductivity of the wall k_wall", {"k14": -1}),
        PhysicalProperty("bath_ledge_heat_transfer", "heat transfer coefficient between bath and ledge h_bath-sl",
                         {"k2": 1, "k7": 1, "k12": 1, "k10": -1}),
        PhysicalProperty("wall_ambient_heat_transfer", "heat transfer coefficient between wall and ambient h_wall-0", {"k18": -1}),
        PhysicalProperty("ledge_area", "side-ledge area A_sl",
                         {"k0": -1, "k1": 1, "k2": 1, "k7": 1, "k8": 1, "k9": 1, "k12": 1, "k13": 1}),
        PhysicalProperty("ledge_density", "density of the frozen ledge rho_sl", {"k0": -1}),
        PhysicalProperty("fusion_enthalpy", "fusion enthalpy of cryolite",
                         {"k1": -1, "k2": -1, "k7": -1, "k8": -1, "k12": -1, "k13": -1}),
        PhysicalProperty("liquid_cryolite_heat_capacity", "heat capacity of liquid cryolite", {"k7": 1, "k8": 1}),
        PhysicalProperty("solid_cryolite_heat_capacity", "heat capacity of solid cryolite", {"k12": 1, "k13": 1}),
        PhysicalProperty("bath_heat_capacity", "heat capacity of the bath (1/alpha)", {"alpha": -1}),
        PhysicalProperty("ledge_heat_capacity", "heat capacity of the ledge (1/beta)", {"beta": -1}),
        PhysicalProperty("wall_heat_capacity", "heat capacity of the wall (1/k17)", {"k17": -1}),
        PhysicalProperty("current_efficiency", "current efficiency (alumina used and metal made per ampere)", {"k3": 1, "k6": 1}),
        PhysicalProperty("alumina_impurity", "Na2O content of the alumina feed", {"k4": 1, "k5": 1}),
    )
}  # fmt: skip
