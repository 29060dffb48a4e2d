"""Shipped test cases: measured-like data in which a physical effect is hidden.

Each case builds a *true* model from the full model (or, for the paper's case, is the
full model itself), simulates trajectories with it, and adds measurement noise; the
discovery workflow gets the noisy data and a *starting* model that lacks the effect,
and is never told what is hidden.  ``expected_equations`` and ``accepted`` say what
a correct answer is; ``accepted`` lists the explanations a correct answer may name
first: the same physics where the naming rule cannot choose (a missing flow into a
balance and the same correction of a flow part that enters only that balance are
indistinguishable from the states alone), and only the cause where it can (the bath
conductivity, not the cell voltage computed from it; the feeder, not a flow in the
alumina balance proportional to its command).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...physics import PROPERTIES, BalanceTerm, CellModel, InputCorrection, PropertyCorrection, ablated_model

__all__ = ["CASES", "HiddenEffectCase", "add_noise"]


@dataclass(frozen=True)
class HiddenEffectCase:
    name: str
    hidden: str
    kind: str
    starting: str  # "ablated": the paper's PBM; "full": the full model
    noise: float  # measurement noise std, as a fraction of each state's std
    expected_equations: tuple[str, ...]
    accepted: tuple[str, ...]
    make_true: Callable[[CellModel], CellModel]

    def models(self, full: CellModel) -> tuple[CellModel, CellModel]:
        """(true model with the effect, starting model without it)."""
        start = ablated_model(full) if self.starting == "ablated" else full
        return self.make_true(full), start


def add_noise(x: np.ndarray, level: float, rng: np.random.Generator) -> np.ndarray:
    """x plus Gaussian noise of std ``level`` times each state's std over the data."""
    scale = level * x.reshape(-1, x.shape[-1]).std(axis=0)
    return x + rng.normal(size=x.shape) * scale


def _unchanged(full: CellModel) -> CellModel:
    return full


def _top_heat_loss(full: CellModel) -> CellModel:
    """Heat lost through the crust and anodes: 22 W/K (x6 - T0), about 10 % of the power."""
    loss = BalanceTerm(
        "top_heat_loss", "22 (x6 - k16)", "W", {"bath_energy": -1.0}, lambda v, k, q: 22.0 * (v.x6 - k.k16)
    )
    return full.with_terms(loss, model_name="full+top heat loss")


def _alf3_evaporation(full: CellModel) -> CellModel:
    """AlF3 evaporates in proportion to its fraction and exponentially with temperature."""
    rate = BalanceTerm(
        "alf3_evaporation", "0.02 c3 exp((x6 - 970)/25)", "kg/s", {"alf3_mass": -1.0},
        lambda v, k, q: 0.02 * v.c3 * v.xp.exp((v.x6 - 970.0) / 25.0),
    )  # fmt: skip
    return full.with_terms(rate, model_name="full+AlF3 evaporation")


def _wall_conductivity(full: CellModel) -> CellModel:
    """The wall's conductivity rises with its temperature: k_wall (1 + 0.004 (x8 - 580)).

    k_wall sets the wall's half resistance k14, which both the ledge-to-wall and the
    wall-to-ambient heat flows go through.
    """
    change = PropertyCorrection(PROPERTIES["wall_conductivity"], "0.004 (x8 - 580)", lambda v: 0.004 * (v.x8 - 580.0))
    return full.with_property(change, model_name="full+wall conductivity(x8)")


def _alumina_dissolution(full: CellModel) -> CellModel:
    """Part of the alumina feed settles as sludge; less of it at a higher superheat."""
    sludge = BalanceTerm(
        "alumina_sludge", "u1 (0.3 - 0.015 (x6 - g1))", "kg/s", {"alumina_mass": -1.0},
        lambda v, k, q: v.u1 * (0.3 - 0.015 * (v.x6 - q["liquidus_temperature"])),
    )  # fmt: skip
    return full.with_terms(sludge, model_name="full+alumina sludge")


def _conductivity_alf3(full: CellModel) -> CellModel:
    """AlF3 lowers the bath's conductivity: g2 exp(-3.5 (c3 - 0.11))."""
    part = full.parts["bath_conductivity"]
    return full.with_part(
        "bath_conductivity",
        part.renamed(
            f"{part.formula} exp(-3.5 (c3 - 0.11))", lambda v, k, q: part(v, k, q) * v.xp.exp(-3.5 * (v.c3 - 0.11))
        ),
    )


def _alumina_feeder(full: CellModel) -> CellModel:
    """The alumina feeder delivers 92 % of its command u1 (a worn dosing chamber, say): less
    alumina dissolves, and less AlF3 is neutralised and less cryolite formed by its impurities."""
    return full.with_input(InputCorrection("u1", "-0.08", lambda v: -0.08), model_name="full+feeder at 92 %")


def _tapping_shortfall(full: CellModel) -> CellModel:
    """The tapping removes 90 % of the metal logged in u4 (the crucible's weight overstates it)."""
    return full.with_input(InputCorrection("u4", "-0.1", lambda v: -0.1), model_name="full+tapping at 90 %")


CASES: dict[str, HiddenEffectCase] = {
    c.name: c
    for c in (
        HiddenEffectCase(
            name="paper_liquidus",
            hidden="the liquidus temperature g1 depends on the bath composition (the PBM fixes it at 968 degC)",
            kind="a part replaced by a constant",
            starting="ablated",
            noise=0.01,
            expected_equations=("x1", "x4", "x6", "x7"),
            accepted=("part:liquidus_temperature",),
            make_true=_unchanged,
        ),
        HiddenEffectCase(
            name="top_heat_loss",
            hidden="a heat loss of 22 W/K (x6 - 35 degC) from the bath through the top",
            kind="a missing flow in an energy balance",
            starting="full",
            noise=0.01,
            expected_equations=("x6",),
            accepted=("term:bath_energy", "part:electric_power", "part:bath_ledge_heat"),
            make_true=_top_heat_loss,
        ),
        HiddenEffectCase(
            name="alf3_evaporation",
            hidden="AlF3 evaporates at 0.02 c3 exp((x6 - 970)/25) kg/s",
            kind="a missing flow in a mass balance",
            starting="full",
            noise=0.005,
            expected_equations=("x3",),
            accepted=("term:alf3_mass",),
            make_true=_alf3_evaporation,
        ),
        HiddenEffectCase(
            name="wall_conductivity",
            hidden="the wall conductivity rises 0.4 %/K with the wall temperature x8",
            kind="a coefficient that depends on a state",
            starting="full",
            noise=0.01,
            expected_equations=("x7", "x8"),
            accepted=("property:wall_conductivity",),
            make_true=_wall_conductivity,
        ),
        HiddenEffectCase(
            name="alumina_dissolution",
            hidden="a fraction 0.3 - 0.015 (x6 - g1) of the alumina feed settles as sludge",
            kind="an efficiency that varies with operating conditions",
            starting="full",
            noise=0.01,
            expected_equations=("x2",),
            accepted=("term:alumina_mass",),
            make_true=_alumina_dissolution,
        ),
        HiddenEffectCase(
            name="conductivity_alf3",
            hidden="the bath conductivity falls with the AlF3 fraction: g2 exp(-3.5 (c3 - 0.11))",
            kind="a coefficient that depends on the composition",
            starting="full",
            noise=0.005,
            expected_equations=("x6",),
            accepted=("part:bath_conductivity",),  # U and P_el, computed from g2, are its consequences
            make_true=_conductivity_alf3,
        ),
        HiddenEffectCase(
            name="alumina_feeder",
            hidden="the alumina feeder delivers 92 % of its command u1",
            kind="an input that is not what reached the cell",
            starting="full",
            noise=0.01,
            expected_equations=("x2",),
            accepted=("input:u1",),
            make_true=_alumina_feeder,
        ),
        HiddenEffectCase(
            name="tapping_shortfall",
            hidden="the tapping removes 90 % of the metal logged in u4",
            kind="an input that is not what reached the cell",
            starting="full",
            noise=0.01,
            expected_equations=("x5",),
            accepted=("input:u4",),
            make_true=_tapping_shortfall,
        ),
        HiddenEffectCase(
            name="no_effect",
            hidden="nothing: the data come from the starting model itself",
            kind="no effect (a null case)",
            starting="full",
            noise=0.01,
            expected_equations=(),
            accepted=(),
            make_true=_unchanged,
        ),
    )
}
