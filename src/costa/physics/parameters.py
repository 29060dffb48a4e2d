"""Constants of the cell model, derived from the physical quantities they stand for.

The paper's Table 2 prints rounded (and in two places different) values of the
constants k0..k18, alpha and beta; the authors' code derives most of them from a
handful of material properties.  :func:`authors_code_parameters` reproduces the
code, :func:`paper_printed_parameters` the printed table.  ``docs/errata.md``
lists every difference and why the code's value is the default.

Numbering follows the paper: k16 is the ambient temperature, k17 the inverse wall
heat capacity, k18 the inverse wall-to-ambient heat transfer coefficient (the code
calls these k19, k17 and k20).  :data:`CONSTANTS` gives each constant's unit and
meaning; :func:`constants_table` lists a cell's constants with where they come from.

Your own cell: the config's ``physics.cell`` section sets the fields of
:class:`MaterialProperties`, from which the constants are derived exactly as for
the paper's cell; ``physics.overrides`` then replaces single constants.  E0 and
R_ext, the pot voltage's parts beyond the bath (channel ``U_pot``, :mod:`costa.observe`),
enter no balance.  A cell that
gives its current efficiency gets k3 and k6 from Faraday's law
(:func:`faraday_constants`); without it they stay the authors' numbers, which make
half of Faraday's metal (``docs/errata.md`` #31).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import pandas as pd

#: Faraday's constant [C/mol] (CODATA 2018; exact in the SI since 2019)
FARADAY = 96485.33212
#: molar masses of aluminium and alumina [kg/mol] (NIST Chemistry WebBook: 26.981538 and 101.9613 g/mol)
MOLAR_MASS_AL = 0.026981538
MOLAR_MASS_AL2O3 = 0.1019613

__all__ = [
    "CONSTANTS",
    "CellParameters",
    "MaterialProperties",
    "authors_code_parameters",
    "constants_table",
    "faraday_constants",
    "paper_printed_parameters",
    "parameters_from_config",
]


@dataclass(frozen=True)
class MaterialProperties:
    """A cell's material and geometry data, from which the model's constants derive.

    Units: conductivities in W/(m K), lengths in m, heat transfer coefficients in
    W/(m^2 K), areas in m^2, density in kg/m^3, enthalpy in J/kg, specific heat
    capacities in J/(kg K), the wall's heat capacity in J/K, temperatures in degC,
    the current efficiency as a fraction (0.95 = 95 %), the back EMF in V and the
    external resistance in ohm.
    The defaults are the paper's cell; the authors' code gives k0, k16, k17, alpha
    and beta as numbers, whose physical values are the next five fields (the
    reciprocals are exact: 1 / (1 / 5.66e-4) == 5.66e-4 in float64).
    ``current_efficiency`` None keeps the code's k3 and k6.  ``back_emf`` and
    ``external_resistance`` are typical values (docs/model.md §2, "The pot voltage") that
    make a pot voltage of 4.2 V at 140 kA for the paper's cell.
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
    ledge_density: float = 2790.178571428571  # rho_sl = 1 / (k0 A_sl) with the code's k0 = 2e-5
    bath_heat_capacity: float = 1766.7844522968198  # c_p,bath = 1 / alpha, alpha = 5.66e-4
    ledge_heat_capacity: float = 1319.2612137203166  # c_p,sl = 1 / beta, beta = 7.58e-4
    wall_heat_capacity: float = 1666666.6666666667  # C_wall = 1 / k17, k17 = 6e-7
    ambient_temperature: float = 35.0  # T_0 = k16
    current_efficiency: float | None = None  # CE: k3 and k6 by Faraday's law where given
    back_emf: float = 1.8  # E0: reversible 1.2 V + anode 0.5 V + cathode 0.1 V over-voltage
    external_resistance: float = 6.8e-6  # R_ext: anode 0.3 V + cathode 0.45 V + bus bars 0.2 V at 140 kA


@dataclass(frozen=True)
class CellParameters:
    """The constants of the cell model (paper numbering).

    Units and meanings are in :data:`CONSTANTS`; :mod:`costa.physics.parts` and
    :mod:`costa.physics.model` show each constant's role in the equations.
    ``critical_alumina_percent`` is c_x2,crit in percent (2.2).  ``E0`` [V] and
    ``R_ext`` [ohm] make the pot voltage U + E0 + R_ext u2 (:mod:`costa.observe`).
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
    E0: float
    R_ext: float
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
    """The constants as the authors' simulator computes them (the default), for any cell's ``material``.

    k4 and k5 (the alumina's impurity) stay the code's numbers.  k3 and k6 (alumina
    used and metal made per ampere) too, unless the cell gives its current efficiency:
    then they follow Faraday's law (:func:`faraday_constants`).
    """
    m = material
    k1 = 2 * m.ledge_conductivity * m.ledge_area / m.cryolite_fusion_enthalpy
    k2 = m.bath_ledge_heat_transfer * m.ledge_area / m.cryolite_fusion_enthalpy
    per_ampere = {"k3": 1.7e-7, "k6": 4.43e-8}
    if m.current_efficiency is not None:
        per_ampere = faraday_constants(m.current_efficiency)
    return CellParameters(
        k0=1 / (m.ledge_density * m.ledge_area),
        k1=k1,
        k2=k2,
        k4=0.02,
        k5=0.03,
        **per_ampere,
        k7=k2 * m.liquid_cryolite_heat_capacity,
        k8=k1 * m.liquid_cryolite_heat_capacity,
        k9=m.ledge_area,
        k10=1 / m.bath_ledge_heat_transfer,
        k11=1 / (2 * m.ledge_conductivity),
        k12=k2 * m.solid_cryolite_heat_capacity,
        k13=k1 * m.solid_cryolite_heat_capacity,
        k14=m.wall_thickness / (2 * m.wall_conductivity),
        k15=1 / (2 * m.ledge_conductivity),
        k16=m.ambient_temperature,
        k17=1 / m.wall_heat_capacity,
        k18=1 / m.wall_ambient_heat_transfer,
        alpha=1 / m.bath_heat_capacity,
        beta=1 / m.ledge_heat_capacity,
        E0=m.back_emf,
        R_ext=m.external_resistance,
    )


def faraday_constants(current_efficiency: float) -> dict[str, float]:
    """k3 and k6 [kg/(A s)] of a cell with this current efficiency [-], by Faraday's law.

    Each Al atom takes 3 electrons, so an ampere makes CE M(Al) / (3 F) of metal (k6)
    and uses half a mole of Al2O3 per mole of Al, CE M(Al2O3) / (6 F) (k3).
    """
    return {
        "k3": current_efficiency * MOLAR_MASS_AL2O3 / (6 * FARADAY),
        "k6": current_efficiency * MOLAR_MASS_AL / (3 * FARADAY),
    }


def paper_printed_parameters() -> CellParameters:
    """The constants exactly as printed in the paper's Table 2 (rounded); E0 and R_ext, which the
    paper does not have, are the default cell's."""
    cell = MaterialProperties()
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
        E0=cell.back_emf,
        R_ext=cell.external_resistance,
    )


_PRESETS = {
    "authors_code": authors_code_parameters,
    "paper_printed": paper_printed_parameters,
}


def parameters_from_config(
    preset: str, overrides: Mapping[str, Any] | None = None, cell: Mapping[str, float] | None = None
) -> CellParameters:
    """Parameters from a preset name, a cell's material data (``authors_code`` only) and per-constant overrides."""
    if preset not in _PRESETS:
        raise ValueError(f"unknown parameter preset {preset!r}; known: {sorted(_PRESETS)}")
    material = MaterialProperties(**dict(cell or {}))
    if preset == "authors_code":
        params = authors_code_parameters(material)
    elif material != MaterialProperties():
        raise ValueError(
            "physics.cell sets material data, but physics.constants = paper_printed takes the printed table as "
            "it is; use constants: authors_code (derived from physics.cell) or physics.overrides"
        )
    else:
        params = paper_printed_parameters()
    return params.replace(**dict(overrides or {}))


#: constant -> (unit, meaning, how it derives from MaterialProperties or "" if a fixed number)
CONSTANTS: dict[str, tuple[str, str, str]] = {
    "k0": ("m/kg", "ledge thickness per kg of ledge", "1 / (ledge_density ledge_area)"),
    "k1": ("kg m/(s K)", "conduction from the freezing front into the ledge, over the fusion enthalpy",
           "2 ledge_conductivity ledge_area / cryolite_fusion_enthalpy"),
    "k2": ("kg/(s K)", "heat transfer from the bath to the ledge, over the fusion enthalpy",
           "bath_ledge_heat_transfer ledge_area / cryolite_fusion_enthalpy"),
    "k3": ("kg/(s A)", "Al2O3 consumed per ampere", ""),
    "k4": ("kg/kg", "AlF3 neutralised per kg of Al2O3 fed (its Na2O impurity)", ""),
    "k5": ("kg/kg", "cryolite formed per kg of Al2O3 fed", ""),
    "k6": ("kg/(s A)", "metal produced per ampere", ""),
    "k7": ("W/K^2", "sensible heat of the bath that freezes (bath side)", "k2 liquid_cryolite_heat_capacity"),
    "k8": ("W m/K^2", "sensible heat of the bath that freezes (front side)", "k1 liquid_cryolite_heat_capacity"),
    "k9": ("m^2", "side-ledge area", "ledge_area"),
    "k10": ("m^2 K/W", "bath-ledge thermal resistance", "1 / bath_ledge_heat_transfer"),
    "k11": ("m K/W", "half the ledge's thermal resistance per thickness", "1 / (2 ledge_conductivity)"),
    "k12": ("W/K^2", "sensible heat of the ledge that forms (bath side)", "k2 solid_cryolite_heat_capacity"),
    "k13": ("W m/K^2", "sensible heat of the ledge that forms (front side)", "k1 solid_cryolite_heat_capacity"),
    "k14": ("m^2 K/W", "half the wall's thermal resistance", "wall_thickness / (2 wall_conductivity)"),
    "k15": ("m K/W", "half the ledge's thermal resistance per thickness", "1 / (2 ledge_conductivity)"),
    "k16": ("degC", "ambient temperature", "ambient_temperature"),
    "k17": ("K/J", "inverse heat capacity of the wall", "1 / wall_heat_capacity"),
    "k18": ("m^2 K/W", "wall-ambient thermal resistance", "1 / wall_ambient_heat_transfer"),
    "alpha": ("kg K/J", "inverse specific heat capacity of the bath", "1 / bath_heat_capacity"),
    "beta": ("kg K/J", "inverse specific heat capacity of the ledge", "1 / ledge_heat_capacity"),
    "E0": ("V", "back EMF: reversible voltage and over-voltages, in the pot voltage U_pot", "back_emf"),
    "R_ext": ("ohm", "resistance of anodes, cathode and bus bars, in the pot voltage U_pot", "external_resistance"),
    "critical_alumina_percent": ("%", "alumina content of the anode effect (in g3)", ""),
}  # fmt: skip
#: constants of this project's own, not in the paper's Table 2 (derived from the cell with either preset)
NOT_PRINTED = ("E0", "R_ext")

#: how k3 and k6 derive where ``physics.cell.current_efficiency`` is given (else they are fixed numbers)
FARADAY_DERIVATION = {
    "k3": "Faraday's law: current_efficiency M(Al2O3) / (6 F)",
    "k6": "Faraday's law: current_efficiency M(Al) / (3 F)",
}


def constants_table(physics: Mapping[str, Any]) -> pd.DataFrame:
    """The constants of a config's ``physics`` section: constant, value, unit, meaning, source.

    ``source`` is the derivation from ``physics.cell`` (constants: authors_code; k3
    and k6 by Faraday's law where the cell gives its current efficiency), "override"
    (``physics.overrides``), "fixed" (a number of the authors' code) or "printed"
    (constants: paper_printed).
    """
    overrides = physics.get("overrides") or {}
    params = parameters_from_config(physics["constants"], overrides, physics.get("cell"))
    derived = physics["constants"] == "authors_code"
    faraday = (physics.get("cell") or {}).get("current_efficiency") is not None
    rows = []
    for name, value in params.as_dict().items():
        unit, meaning, formula = CONSTANTS[name]
        if name in overrides:
            source = "override"
        elif not derived and name not in NOT_PRINTED:
            source = "printed"
        elif faraday and name in FARADAY_DERIVATION:
            source = FARADAY_DERIVATION[name]
        else:
            source = formula or "fixed"
        rows.append({"constant": name, "value": value, "unit": unit, "meaning": meaning, "source": source})
    return pd.DataFrame(rows)
