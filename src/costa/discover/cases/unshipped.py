"""Hidden effects the workflow was not designed around: cases that are not shipped.

They are built like the shipped cases (:mod:`.shipped`) but are not in ``discovery.cases``'
default: ``pytest -m slow`` checks that discovery generalises to them, and the peers
stage (:mod:`costa.peers`) compares methods on them.  These effects are small (the
starting model is within about 2x of the noise floor).
"""

from __future__ import annotations

from dataclasses import replace

from ...physics import PROPERTIES, CellModel, PropertyCorrection
from .shipped import CASES, HiddenEffectCase

__all__ = ["UNSHIPPED", "find_case"]


def _printed_k4(full: CellModel) -> CellModel:
    return replace(full, params=full.params.replace(k4=0.036), name="full with the printed k4")


def _varying(property_name: str, formula: str, fn):
    return lambda full: full.with_property(PropertyCorrection(PROPERTIES[property_name], formula, fn))


UNSHIPPED: dict[str, HiddenEffectCase] = {
    c.name: c
    for c in (
        HiddenEffectCase(name="printed_k4", hidden="k4 = 0.036 (printed) instead of 0.02", kind="a wrong constant", starting="full", noise=0.01,
                         expected_equations=("x3",), accepted=("term:alf3_mass", "part:alf3_neutralisation"), make_true=_printed_k4),
        HiddenEffectCase(name="bath_heat_capacity", hidden="the bath's heat capacity 10 % lower", kind="a wrong property", starting="full", noise=0.01,
                         expected_equations=("x6",), accepted=("property:bath_heat_capacity",),
                         make_true=_varying("bath_heat_capacity", "0.1111", lambda v: 0.1111 + 0 * v.x6)),
        HiddenEffectCase(name="current_efficiency", hidden="current efficiency (1 - 0.005 (x6 - 970))", kind="an efficiency", starting="full",
                         noise=0.01, expected_equations=("x2",), accepted=("property:current_efficiency",),
                         make_true=_varying("current_efficiency", "-0.005 (x6 - 970)", lambda v: -0.005 * (v.x6 - 970.0))),
        HiddenEffectCase(name="ledge_conductivity", hidden="k_sl (1 - 0.002 (x7 - 820))", kind="a state-dependent property", starting="full",
                         noise=0.01, expected_equations=("x1", "x4", "x6", "x7", "x8"),
                         accepted=("property:ledge_conductivity", "property:ledge_density"),
                         make_true=_varying("ledge_conductivity", "-0.002 (x7 - 820)", lambda v: -0.002 * (v.x7 - 820.0))),
    )
}  # fmt: skip


def find_case(name: str) -> HiddenEffectCase:
    """A shipped case, an unshipped one or a drawn one (``drawn<seed>``, :mod:`.drawn`), by name
    (the shipped registry is read at call time)."""
    from .drawn import DRAWN_NAME, drawn_case

    if DRAWN_NAME.fullmatch(name):
        return drawn_case(name)
    cases = {**CASES, **UNSHIPPED}
    if name not in cases:
        raise ValueError(f"unknown discovery case {name!r}; known: {sorted(cases)} and drawn<seed>")
    return cases[name]
