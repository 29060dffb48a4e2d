"""Constants of the cell model, derived from the physical quantities they stand for.

The paper's Table 2 prints rounded (and in two places different) values of the
constants k0..k18, alpha and beta; the authors' code derives most of them from a
handful of material properties.  :func:`authors_code_parameters` reproduces the
code, :func:`paper_printed_parameters` the printed table.  ``docs/errata.md``
lists every difference and why the code's value is the default.

Numbering follows the paper: k16 is the ambient temperature, k17 the inverse wall
heat capacity, k18 the inverse wall-to-ambient heat transfer coefficient (the code
calls these k19, k17 and k20).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

__all__ = [
    "CellParameters",
    "MaterialProperties",
    "authors_code_parameters",
    "paper_printed_parameters",
    "parameters_from_config",
]


@dataclass(frozen=True)
class MaterialProperties:
    """Material and geometry data from which the code derives its constants.

    Units: conductivities in W/(m K), lengths in m, heat transfer coefficients in
    W/(m^2 K), areas in m^2, enthalpy in J/kg, heat capacities in J/(kg K).
    """

    ledge_conductivity: float = 2.5  # k_sl
    wall_conductivity: float = 6.5  # k_wall
    wall_thickness: float = 0.1  # x_wall
    bath_ledge_heat_transfer: float = 1200.0  # h_bath-sl
    wall_ambient_heat_transfer: float = 25.0  # h_wall-0
    ledge_area: float = 17.92  # A_sl
    cryolite_fusion_enthalpy: float = 119495.0  # Delta_fus H_cry
    liquid_cryolite_heat_capacity: float = 1881.0  # c_p,cry,liq
    solid_cryolite_heat_capacity: float = 1320.0  # c_p,cry,s


@dataclass(frozen=True)
class CellParameters:
    """The constants of the cell model (paper numbering).

    Attributes carry the units of the terms they multiply; see the module
    docstring of :mod:`costa.physics.balances` for their role in each equation.
    ``critical_alumina_percent`` is c_x2,crit in percent (2.2).
    """

    k0: float
    k1: float
    k2: float
    k3: float
    k4: float
    k5: float
    k6: float
    k7: float
    k8: float
    k9: float
    k10: float
    k11: float
    k12: float
    k13: float
    k14: float
    k15: float
    k16: float
    k17: float
    k18: float
    alpha: float
    beta: float
    critical_alumina_percent: float = 2.2

    def replace(self, **changes: float) -> CellParameters:
        """Return a copy with some constants changed; unknown names raise ``ValueError``."""
        known = {f.name for f in dataclasses.fields(self)}
        unknown = sorted(set(changes) - known)
        if unknown:
            raise ValueError(f"unknown cell parameter(s) {unknown}; known: {sorted(known)}")
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict[str, float]:
        return dataclasses.asdict(self)


def authors_code_parameters(
    material: MaterialProperties = MaterialProperties(),
) -> CellParameters:
    """The constants as the authors' simulator computes them (the default)."""
    m = material
    k1 = 2 * m.ledge_conductivity * m.ledge_area / m.cryolite_fusion_enthalpy
    k2 = m.bath_ledge_heat_transfer * m.ledge_area / m.cryolite_fusion_enthalpy
    return CellParameters(
        k0=2e-5,
        k1=k1,
        k2=k2,
        k3=1.7e-7,
        k4=0.02,
        k5=0.03,
        k6=4.43e-8,
        k7=k2 * m.liquid_cryolite_heat_capacity,
        k8=k1 * m.liquid_cryolite_heat_capacity,
        k9=m.ledge_area,
        k10=1 / m.bath_ledge_heat_transfer,
        k11=1 / (2 * m.ledge_conductivity),
        k12=k2 * m.solid_cryolite_heat_capacity,
        k13=k1 * m.solid_cryolite_heat_capacity,
        k14=m.wall_thickness / (2 * m.wall_conductivity),
        k15=1 / (2 * m.ledge_conductivity),
        k16=35.0,
        k17=6e-7,
        k18=1 / m.wall_ambient_heat_transfer,
        alpha=5.66e-4,
        beta=7.58e-4,
    )


def paper_printed_parameters() -> CellParameters:
    """The constants exactly as printed in the paper's Table 2 (rounded)."""
    return CellParameters(
        k0=2e-5,
        k1=7.5e-4,
        k2=0.18,
        k3=1.7e-7,
        k4=0.036,
        k5=0.03,
        k6=4.43e-8,
        k7=338.0,
        k8=1.41,
        k9=17.92,
        k10=0.00083,
        k11=0.2,
        k12=237.5,
        k13=0.99,
        k14=0.0077,
        k15=0.2,
        k16=35.0,
        k17=5.8e-7,
        k18=0.04,
        alpha=5.66e-4,
        beta=7.58e-4,
    )


_PRESETS = {
    "authors_code": authors_code_parameters,
    "paper_printed": paper_printed_parameters,
}


def parameters_from_config(preset: str, overrides: Mapping[str, Any] | None = None) -> CellParameters:
    """Build parameters from a preset name and optional per-constant overrides."""
    if preset not in _PRESETS:
        raise ValueError(f"unknown parameter preset {preset!r}; known: {sorted(_PRESETS)}")
    return _PRESETS[preset]().replace(**dict(overrides or {}))
