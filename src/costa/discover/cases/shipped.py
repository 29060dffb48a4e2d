"""Shipped test cases: measured-like data in which a physical effect is hidden.

Each case builds a *true* model from the full model (or, for the paper's case, is the
full model itself), simulates trajectories with it, and adds measurement noise; the
discovery workflow gets the noisy data and a *starting* model that lacks the effect,
and is never told what is hidden.  The cases are a table, ``shipped.yaml`` beside this
module; their true models are the functions here.  ``expected_equations`` and ``accepted`` say what
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
from importlib import resources

import numpy as np
import yaml

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


#: the functions that build a case's true model from the full one, by the name shipped.yaml gives
TRUE_MODELS: dict[str, Callable[[CellModel], CellModel]] = {
    f.__name__.removeprefix("_"): f
    for f in (_unchanged, _top_heat_loss, _alf3_evaporation, _wall_conductivity, _alumina_dissolution,
              _conductivity_alf3, _alumina_feeder, _tapping_shortfall)
}  # fmt: skip


def _shipped() -> dict[str, HiddenEffectCase]:
    """The cases of shipped.yaml, in its order."""
    table = yaml.safe_load(resources.files(__package__).joinpath("shipped.yaml").read_text())
    return {
        name: HiddenEffectCase(
            name=name,
            hidden=row["hidden"],
            kind=row["kind"],
            starting=row["starting"],
            noise=float(row["noise"]),
            expected_equations=tuple(row["expected_equations"]),
            accepted=tuple(row["accepted"]),
            make_true=TRUE_MODELS[row["true_model"]],
        )  # fmt: skip
        for name, row in table.items()
    }


CASES: dict[str, HiddenEffectCase] = _shipped()
