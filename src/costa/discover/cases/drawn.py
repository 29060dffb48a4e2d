"""Hidden effects drawn at random: the cases of the discovery benchmark (``drawn<seed>``).

A drawn case is a pure function of its seed.  Its seed draws a kind (a part's law, a flow
missing from a balance, a flow between two balances, a physical property, the gain of an input,
or nothing: a null case), where it acts, a closed form from families inside the term library
(a constant, a line, a product of two variables) and outside it (an exponential, a saturating
curve, a threshold), a size log-uniform over two decades, and the measurement noise; the cells,
their inputs and the noise draws then come from the case's name (:mod:`.tables`).

A correction of size ``a`` changes a part, a property or an input by the relative amount
``a f(z)``, and adds the flow ``a F_b f(z)`` to a balance (``F_b`` its typical flow,
:data:`TYPICAL_FLOW`); half the effects on the line current and the anode-cathode distance are an
offset instead of a gain, ``a U_i f(z)`` added to the logged input (``U_i`` its typical value,
:data:`TYPICAL_INPUT`: a shunt read off zero, a beam's scale set wrong), where ``z = (variable - centre) / spread`` is held in [-2, 2] and each
family is scaled to stay within [-2, 2] there: ``|a f| <= 0.2`` of the thing it changes.

Which names are right is computed, not typed: the hypothesis whose correction the effect is,
and every other hypothesis whose sensitivity is the same up to a constant factor at the
operating points (a flow out of a part that enters one balance only is that balance's missing
flow).  Drawn cases are never used to choose a rule on the ``test`` seeds (:data:`SPLITS`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cache

import numpy as np

from ... import seeds
from ...physics import (
    BALANCES,
    PART_ORDER,
    PROPERTIES,
    BalanceTerm,
    CellModel,
    InputCorrection,
    PropertyCorrection,
    true_model,
)  # fmt: skip
from ...variables import INPUTS, STATES, UNIT
from ..core.hypotheses import candidate_hypotheses, generic_points, same_sensitivity
from .shipped import HiddenEffectCase

__all__ = ["DRAWN_NAME", "SPLITS", "DrawnEffect", "draw_effect", "drawn_case", "effect_case", "split_cases"]

#: a drawn case's name: ``drawn`` and its seed
DRAWN_NAME = re.compile(r"drawn(\d+)")
#: the seed ranges: ``dev`` to tune on freely, ``test`` to report on only (never to choose a rule)
SPLITS: dict[str, range] = {"dev": range(0, 100_000), "test": range(100_000, 200_000)}
#: the kinds drawn, and the share of null cases (nothing hidden)
KINDS = ("part", "term", "transfer", "property", "input")
NULL_SHARE = 0.15
#: the size a, log-uniform between these (a relative change of a at |f| = 1)
SIZE_RANGE = (0.001, 0.1)
#: the measurement noise of the full set, log-uniform between these (a fraction of each state's std)
NOISE_RANGE = (0.003, 0.03)
#: variable -> (centre, spread) of z = (variable - centre) / spread
VARIABLES: dict[str, tuple[float, float]] = {
    "x6": (970.0, 8.0), "x7": (820.0, 25.0), "x8": (580.0, 30.0), "x1": (3000.0, 800.0),
    "c2": (0.03, 0.005), "c3": (0.11, 0.01), "m": (16000.0, 1500.0), "u2": (140000.0, 8000.0),
}  # fmt: skip
#: a typical flow through each balance at the operating point (kg/s or W): the flow a missing one is sized on
TYPICAL_FLOW = {
    "ledge_mass": 0.02, "alumina_mass": 0.023, "alf3_mass": 0.024, "cryolite_mass": 0.036, "metal_mass": 0.006,
    "bath_energy": 2e5, "ledge_energy": 2e5, "wall_energy": 2e5,
}  # fmt: skip
#: a part in degC changes by a F f(z) with this F (a relative change of a liquidus would be tens of kelvin)
TYPICAL_TEMPERATURE = 10.0
#: the inputs that may be read with an offset, and their typical value (A, m): an offset is a U_i f(z)
TYPICAL_INPUT = {"u2": 140000.0, "u5": 0.05}
#: the share of the effects on those inputs that are an offset rather than a gain
OFFSET_SHARE = 0.5
#: the families: (name, number of variables, inside the term library)
FAMILIES = (
    ("constant", 0, True), ("linear", 1, True), ("product", 2, True),
    ("exponential", 1, False), ("saturating", 1, False), ("threshold", 1, False),
)  # fmt: skip


@dataclass(frozen=True, kw_only=True)
class DrawnEffect:
    """One drawn effect: ``key`` is the hypothesis whose correction it is (None for a null case)."""

    seed: int
    kind: str  # a KINDS entry, or "none"
    target: str  # a part, balance, "a->b", property or input ("" for a null case)
    family: str
    variables: tuple[str, ...]
    size: float  # signed a
    noise: float
    offset: bool = False  # an input read with an offset (added to it), not a gain

    @property
    def key(self) -> str | None:
        return None if self.kind == "none" else f"{self.kind}:{self.target}"

    @property
    def in_library(self) -> bool:
        return dict((f, inside) for f, _, inside in FAMILIES)[self.family]

    def shape(self, v):
        """f(z) at cell variables v (an array, or a traced row: only +, *, /, abs and exp)."""
        z = [_held((getattr(v, name) - VARIABLES[name][0]) / VARIABLES[name][1]) for name in self.variables]
        match self.family:
            case "constant":
                return 1.0 + 0.0 * v.x6
            case "linear":
                return z[0]
            case "product":
                return 0.5 * z[0] * z[1]
            case "exponential":
                return (v.xp.exp(z[0]) - 1.0) / (2.0 * (np.e - 1.0))
            case "saturating":
                return 1.5 * z[0] / (1.0 + abs(z[0]))
            case "threshold":
                return 0.5 * (z[0] + abs(z[0]))
        raise ValueError(f"unknown family {self.family!r}")

    def shape_formula(self) -> str:
        z = [f"z({name})" for name in self.variables]
        return {
            "constant": "1", "linear": z[0] if z else "", "product": "0.5 " + " ".join(z),
            "exponential": f"(exp({z[0]}) - 1)/(2 (e - 1))" if z else "",
            "saturating": f"1.5 {z[0]}/(1 + |{z[0]}|)" if z else "", "threshold": f"max(0, {z[0]})" if z else "",
        }[self.family]  # fmt: skip

    def describe(self) -> str:
        if self.kind == "none":
            return "nothing: the data come from the starting model itself"
        scaled = {"term": TYPICAL_FLOW.get(self.target), "transfer": TYPICAL_FLOW.get(self.target.split("->")[0])}
        factor = f"{self.size:.3g}" + (f" x {scaled[self.kind]:g}" if self.kind in scaled else "")
        match self.kind:
            case "part":
                where = f"the part {self.target} changes by {'' if self._absolute_part else 'its value x '}"
            case "term":
                where = f"a flow is missing from the {self.target} balance: "
            case "transfer":
                where = f"a flow moves from {self.target.replace('->', ' to ')}: "
            case "property":
                where = f"the {PROPERTIES[self.target].meaning} changes by a relative "
            case _ if self.offset:
                where = f"the {self.target} reaching the cell is the logged one + "
            case _:
                where = f"the {self.target} reaching the cell is the logged one x (1 + "
        if self._absolute_part:
            factor += f" x {TYPICAL_TEMPERATURE:g} degC"
        if self.offset:
            factor += f" x {TYPICAL_INPUT[self.target]:g} {UNIT[self.target]}"
        close = ")" if self.kind == "input" and not self.offset else ""
        spans = ", ".join(f"z({n}) = ({n} - {c:g})/{s:g}" for n, (c, s) in VARIABLES.items() if n in self.variables)
        return f"{where}{factor} {self.shape_formula()}{close}" + (f", {spans}, held in [-2, 2]" if spans else "")

    @property
    def _absolute_part(self) -> bool:
        return self.kind == "part" and true_model().parts[self.target].unit == "degC"

    def true_model(self, full: CellModel) -> CellModel:
        """``full`` with this effect put in."""
        a, name = self.size, f"full+drawn {self.seed}"
        match self.kind:
            case "none":
                return full
            case "part":
                part = full.parts[self.target]
                if self._absolute_part:
                    fn = lambda v, k, q, p=part: p(v, k, q) + a * TYPICAL_TEMPERATURE * self.shape(v)  # noqa: E731
                else:
                    fn = lambda v, k, q, p=part: p(v, k, q) * (1.0 + a * self.shape(v))  # noqa: E731
                return full.with_part(self.target, part.renamed(f"{part.formula} (drawn)", fn), model_name=name)
            case "term" | "transfer":
                source, _, sink = self.target.partition("->")
                targets = {source: -1.0, sink: 1.0} if sink else {source: 1.0}
                flow, unit = a * TYPICAL_FLOW[source], BALANCES[source][1]
                term = BalanceTerm(f"drawn_{self.seed}", self.describe(), unit, targets,
                                   lambda v, k, q: flow * self.shape(v))  # fmt: skip
                return full.with_terms(term, model_name=name)
            case "property":
                correction = PropertyCorrection(PROPERTIES[self.target], self.describe(), lambda v: a * self.shape(v))
                return full.with_property(correction, model_name=name)
            case "input" if self.offset:
                shift, target = a * TYPICAL_INPUT[self.target], self.target
                gain = lambda v: shift * self.shape(v) / getattr(v, target)  # noqa: E731  (u + b = u (1 + b/u))
                return full.with_input(InputCorrection(target, self.describe(), gain), model_name=name)
            case "input":
                return full.with_input(InputCorrection(self.target, self.describe(), lambda v: a * self.shape(v)),
                                       model_name=name)  # fmt: skip
        raise ValueError(f"unknown kind {self.kind!r}")


def _held(z):
    """z held in [-2, 2] (with abs only, so that a traced row compiles it)."""
    z = 0.5 * (z + 2.0 + abs(z + 2.0)) - 2.0  # max(z, -2)
    return 2.0 - 0.5 * (2.0 - z + abs(2.0 - z))  # min(z, 2)


def _targets(kind: str) -> list[str]:
    if kind == "part":
        return list(PART_ORDER)
    if kind == "term":
        return list(BALANCES)
    if kind == "transfer":
        return [h.target for h in candidate_hypotheses(true_model()) if h.kind == "transfer"]
    if kind == "property":
        return list(PROPERTIES)
    return list(INPUTS)


def draw_effect(seed: int) -> DrawnEffect:
    """The effect of case ``drawn<seed>`` (its own random stream: the same seed, the same effect)."""
    rng = seeds.numpy_generator(seed, 0, "benchmark/effect")
    noise = float(np.exp(rng.uniform(*np.log(NOISE_RANGE))))
    if rng.random() < NULL_SHARE:
        return DrawnEffect(seed=seed, kind="none", target="", family="constant", variables=(), size=0.0, noise=noise)
    kind = KINDS[rng.integers(len(KINDS))]
    targets = _targets(kind)
    target = targets[rng.integers(len(targets))]
    family, count, _ = FAMILIES[rng.integers(len(FAMILIES))]
    names = list(VARIABLES)
    variables = tuple(names[i] for i in rng.choice(len(names), size=count, replace=False))
    size = float(np.exp(rng.uniform(*np.log(SIZE_RANGE)))) * (1.0 if rng.random() < 0.5 else -1.0)
    # drawn last, so that every other draw of a case is as it was before offsets were drawn
    offset = kind == "input" and target in TYPICAL_INPUT and bool(rng.random() < OFFSET_SHARE)
    return DrawnEffect(seed=seed, kind=kind, target=target, family=family, variables=variables, size=size,
                       noise=noise, offset=offset)  # fmt: skip


@cache
def drawn_case(name: str) -> HiddenEffectCase:
    """The case ``drawn<seed>``."""
    match = DRAWN_NAME.fullmatch(name)
    if match is None:
        raise ValueError(f"{name!r} is not a drawn case's name (drawn<seed>)")
    return effect_case(draw_effect(int(match.group(1))))


def effect_case(effect: DrawnEffect) -> HiddenEffectCase:
    """A case with ``effect`` hidden: its effect on the full model, the equations it changes, the names
    that are right (named ``drawn<seed>``: its cells and noise come from the name)."""
    full = true_model()
    x, u = generic_points()
    accepted = equivalent_names(effect, full) if effect.key else ()
    kind = f"{effect.kind} offset" if effect.offset else effect.kind
    return HiddenEffectCase(
        name=f"drawn{effect.seed}", hidden=effect.describe(), kind=f"drawn: {kind} ({effect.family})", starting="full", noise=effect.noise,
        expected_equations=changed_states(effect.true_model(full), full, x, u), accepted=accepted, make_true=effect.true_model,
    )  # fmt: skip


def split_cases(split: str, count: int) -> list[str]:
    """The first ``count`` drawn cases of a seed range."""
    seeds_ = SPLITS[split]
    if count > len(seeds_):
        raise ValueError(f"the {split!r} seeds hold {len(seeds_)} cases, not {count}")
    return [f"drawn{seed}" for seed in seeds_[:count]]


def changed_states(true: CellModel, start: CellModel, x: np.ndarray, u: np.ndarray) -> tuple[str, ...]:
    """The states whose rate the effect changes at the operating points."""
    with np.errstate(all="ignore"):
        a, b = true.rhs(x, u), start.rhs(x, u)
    scale = np.nanmax(np.abs(b), axis=0) + 1e-300
    return tuple(s for s, d in zip(STATES, np.nanmax(np.abs(a - b), axis=0) > 1e-9 * scale, strict=True) if d)


def equivalent_names(effect: DrawnEffect, full: CellModel) -> tuple[str, ...]:
    """The effect's own hypothesis, then every other whose sensitivity is the same up to one constant
    factor at every operating point (:func:`..core.hypotheses.same_sensitivity`): the data cannot tell
    them apart, whatever the closed form."""
    hypotheses = candidate_hypotheses(full)
    own = next(h for h in hypotheses if h.key == effect.key)
    return (own.key, *(h.key for h in hypotheses if h.key != own.key and same_sensitivity(h, own, full)))
