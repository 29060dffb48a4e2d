"""Candidate explanations of a disagreement: a wrong part, a flow missing from the balances,
a wrong physical property, or an input that is not what reached the cell.

Each hypothesis is one unknown function delta(t) entering the state rates through a
known sensitivity J_h(x, u) (8,):

- ``part:<name>``: the part's value is off by delta (in the part's unit); J is the
  derivative of dx/dt with respect to that value (numerically, at the current model);
- ``term:<balance>``: a flow delta (kg/s or W) is missing from one balance; J is 1
  for a mass balance, alpha/m, beta/x1 or k17 for an energy balance;
- ``transfer:<a>-><b>``: a flow leaves balance a and enters balance b (same unit);
- ``property:<name>``: a physical property shared by several constants (a
  conductivity, a heat capacity, the current efficiency) is off by a relative delta,
  which rescales each constant it enters (:mod:`costa.physics.properties`);
- ``input:<u>``: the input reaching the cell is the logged one times (1 + delta) (a feeder
  that delivers less than its command); J = d(dx/dt)/du * u, through every part and
  balance that reads the input.

Hypotheses with the same J explain the data equally well; the closed form and, on a
tie, :data:`PREFERENCE` decide which one is named (the others are reported as
equivalent).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cache

import numpy as np

from ... import seeds
from ...physics import (
    BALANCES,
    PART_ORDER,
    PROPERTIES,
    BalanceTerm,
    CellModel,
    CellVariables,
    InputCorrection,
    PropertyCorrection,
    operating_points,
)  # fmt: skip
from ...variables import INPUTS, MEANING
from .library import Feature, evaluate, feature_library

__all__ = ["Hypothesis", "candidate_hypotheses", "generic_points", "proportional", "same_sensitivity"]


@dataclass(frozen=True)
class Hypothesis:
    """One candidate explanation; ``target`` is a part name or the balances a flow enters."""

    key: str
    kind: str
    target: str
    unit: str
    targets: Mapping[str, float] = field(default_factory=dict)

    def describe(self, model: CellModel) -> str:
        if self.kind == "part":
            part = model.parts[self.target]
            return f"the {part.name.replace('_', ' ')} {part.symbol} [{part.unit}] is not as modelled ({part.symbol} = {part.formula})"
        if self.kind == "term":
            return f"a flow [{self.unit}] is missing from the {self.target.replace('_', ' ')} balance"
        if self.kind == "property":
            return f"the {PROPERTIES[self.target].meaning} is not as modelled (a relative change, rescaling the constants it enters)"
        if self.kind == "input":
            return (
                f"the {MEANING[self.target]} {self.target} reaching the cell is not the logged one "
                "(a relative gain, wherever the model reads it)"
            )
        source, sink = self.target.split("->")
        return f"a flow [{self.unit}] from the {source.replace('_', ' ')} balance to the {sink.replace('_', ' ')} balance is missing"

    @property
    def is_flow(self) -> bool:
        """Whether its correction is a flow: a part or term in W or kg/s, or the gain of a logged input."""
        return self.unit in ("kg/s", "W") or self.kind == "input"

    def features(self, rich: bool = False) -> list[Feature]:
        """The term library.  A part's correction may read only the quantities computed before
        it, and a part that is not a flow (kg/s or W) may not depend on the feed and tapping flows."""
        library = feature_library(relative=self.kind == "part", rich=rich)
        if self.kind in ("property", "input"):
            # a property of the materials, or an actuator's gain: states and operating conditions only
            return [f for f in library if not f.needs and not f.reads_flow_inputs]
        if self.kind != "part":
            return library
        available = set(PART_ORDER[: PART_ORDER.index(self.target)])
        return [f for f in library if f.needs <= available and (self.is_flow or not f.reads_flow_inputs)]

    def sensitivity(self, model: CellModel, x: np.ndarray, u: np.ndarray, base: np.ndarray | None = None) -> np.ndarray:
        """dx/dt per unit of delta (..., 8) at the current model; ``base`` = model.rhs(x, u) if known."""
        if self.kind in ("part", "property", "input"):
            with np.errstate(all="ignore"):
                base = model.rhs(x, u) if base is None else base
        if self.kind in ("property", "input"):
            with np.errstate(all="ignore"):
                bumped = self._with(model, lambda v, q, own: 1e-6, "1e-6")
                return (bumped.rhs(x, u) - base) / 1e-6
        if self.kind != "part":
            per_flow = model.state_rate_per_flow(x, u)
            rates = np.zeros_like(per_flow)
            for balance, coefficient in self.targets.items():
                index = list(BALANCES).index(balance)
                rates[..., index] = coefficient * per_flow[..., index]
            return rates
        part = model.parts[self.target]
        with np.errstate(all="ignore"):
            value = model.quantities(x, u)[self.target]
            step = 1e-6 * (np.nanmean(np.abs(value)) + 1e-9)
            bumped = model.with_part(self.target, part.renamed("+step", lambda v, k, q: part(v, k, q) + step))
            return (bumped.rhs(x, u) - base) / step

    def feature_values(self, model: CellModel, features: Sequence[Feature], x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """theta (..., P) at the data; for a part, ``own`` is the part's value in ``model``."""
        v = CellVariables(x, u)
        with np.errstate(all="ignore"):
            q = model.quantities(x, u)
        own = q[self.target] if self.kind == "part" else None
        return evaluate(list(features), v, q, own)

    def corrected(self, model: CellModel, features: Sequence[Feature], coefficients: Sequence[float]) -> CellModel:
        """``model`` with this hypothesis' correction sum_k xi_k theta_k put in."""
        features, coefficients = list(features), [float(c) for c in coefficients]

        def correction(v, q, own):
            return sum(c * f(v, q, own) for f, c in zip(features, coefficients, strict=True))

        own = model.parts[self.target].symbol if self.kind == "part" else "own"
        return self._with(model, correction, self.formula(features, coefficients, own=own))

    def parametrised(
        self, model: CellModel, features: Sequence[Feature], source: Callable[[], np.ndarray]
    ) -> CellModel:
        """``model`` with the correction sum_k theta_k f_k, its coefficients read from ``source()``
        (rows, terms) at every evaluation: each row of a batch carries its own coefficients."""
        features = list(features)

        def correction(v, q, own):
            theta = source()
            return sum(theta[:, k] * f(v, q, own) for k, f in enumerate(features))

        return self._with(model, correction, "theta")

    def shifted(self, model: CellModel, values: np.ndarray) -> CellModel:
        """``model`` with delta given sample by sample (an array shaped like the data it will see)."""
        return self._with(model, lambda v, q, own: values, "delta(t)")

    def driven(self, model: CellModel, source: Callable[[], np.ndarray]) -> CellModel:
        """``model`` with delta read from ``source()`` at every evaluation (a batch's current values)."""
        return self._with(model, lambda v, q, own: source(), "delta(t)")

    def _with(self, model: CellModel, correction, formula: str) -> CellModel:
        if self.kind in ("property", "input"):
            # one correction per property or input: a further change adds to the delta already
            # there, so that derivatives taken at a corrected model are derivatives in delta
            prop = self.kind == "property"
            name = "properties" if prop else "inputs"
            here = [(c.property.name if prop else c.input) == self.target for c in getattr(model, name)]
            earlier = next((c for c, same in zip(getattr(model, name), here, strict=True) if same), None)
            rest = tuple(c for c, same in zip(getattr(model, name), here, strict=True) if not same)
            if earlier is not None:
                formula = f"{earlier.formula} + {formula}"

            def fn(v):
                return (earlier.fn(v) if earlier is not None else 0.0) + correction(v, {}, None)

            if prop:
                merged = PropertyCorrection(PROPERTIES[self.target], formula, fn)
            else:
                merged = InputCorrection(self.target, formula, fn)
            return dataclasses.replace(model, **{name: (*rest, merged)})
        if self.kind == "part":
            part = model.parts[self.target]
            return model.with_part(
                self.target,
                part.renamed(f"{part.formula} + {formula}", lambda v, k, q: _plus(part(v, k, q), correction, v, q)),
            )
        term = BalanceTerm(
            f"discovered_{self.target.replace('->', '_to_')}", formula, self.unit, dict(self.targets),
            lambda v, k, q: correction(v, q, None),
        )  # fmt: skip
        return model.with_terms(term, model_name=model.name)

    @staticmethod
    def formula(features: Sequence[Feature], coefficients: Sequence[float], own: str = "own") -> str:
        """The correction as text, e.g. ``-1.2e+04 + 38.5*(x6 - 970)``."""
        parts = []
        for f, c in zip(features, coefficients, strict=True):
            name = f.name.replace("own", own)
            parts.append(f"{c:.4g}" if name == "1" else f"{c:.4g}*{name}")
        return " + ".join(parts).replace("+ -", "- ") or "0"


def _plus(own, correction, v, q):
    """A part's value plus its correction, which may read the part's own value."""
    return own + correction(v, q, own)


#: On a tie, which kind is named first: an input that is not what reached the cell (a
#: logged feed or tapping, wrong, is the same as a flow proportional to it in its balance,
#: but it is the cause); then an added flow, which reads as physics unless the data need the
#: part's own value (a relative correction), which then wins the BIC anyway.
PREFERENCE = {"input": 0, "term": 1, "transfer": 2, "part": 3, "property": 4}


def candidate_hypotheses(model: CellModel, constant: Sequence[str] = ()) -> list[Hypothesis]:
    """Every part, every balance, every pair of balances of the same unit, every physical
    property, every input but the ``constant`` ones: an input that did not vary in the record (or
    was not logged) cannot show a delivered share that differs from its log, and its correction,
    a gain read from the states, is then a source in the balances it enters that the term
    hypotheses already hold (with the line current and the anode distance constant, an
    anode-distance gain was named for a top heat loss)."""
    hypotheses = [
        Hypothesis(key=f"part:{name}", kind="part", target=name, unit=model.parts[name].unit) for name in PART_ORDER
    ]
    hypotheses += [Hypothesis(key=f"property:{name}", kind="property", target=name, unit="-") for name in PROPERTIES]
    hypotheses += [
        Hypothesis(key=f"input:{name}", kind="input", target=name, unit="-") for name in INPUTS if name not in constant
    ]
    for balance, (_, unit) in BALANCES.items():
        hypotheses.append(
            Hypothesis(key=f"term:{balance}", kind="term", target=balance, unit=unit, targets={balance: 1.0})
        )
    names = list(BALANCES)
    for i, source in enumerate(names):
        for sink in names[i + 1 :]:
            if BALANCES[source][1] == BALANCES[sink][1]:
                hypotheses.append(
                    Hypothesis(
                        key=f"transfer:{source}->{sink}",
                        kind="transfer",
                        target=f"{source}->{sink}",
                        unit=BALANCES[source][1],
                        targets={source: -1.0, sink: 1.0},
                    )
                )
    return hypotheses


@cache
def generic_points() -> tuple[np.ndarray, np.ndarray]:
    """256 states (256, 8) and inputs (256, 5) over the cell's operating range, from a fixed stream
    (named for the benchmark, which first used it): where two hypotheses are judged alike to any
    measurement, not only to one record's (on a pot line's constant current more of them look alike)."""
    return operating_points(seeds.numpy_generator(0, 0, "benchmark/operating_points"), 256)


def proportional(a: np.ndarray, b: np.ndarray, tolerance: float = 1e-4) -> bool:
    """Whether a = c b for one constant c != 0 (least squares; the residual within ``tolerance`` of |a|)."""
    a, b = a.ravel(), b.ravel()
    bb = b @ b
    if bb == 0 or a @ a == 0:
        return False
    c = (a @ b) / bb
    return bool(c != 0 and np.linalg.norm(a - c * b) <= tolerance * np.linalg.norm(a))


def same_sensitivity(a: Hypothesis, b: Hypothesis, model: CellModel) -> bool:
    """Whether a unit of ``a``'s delta changes every state rate as a constant multiple of ``b``'s does, at
    :func:`generic_points`: then no measurement tells the two apart, whatever their closed forms (a heat
    flow missing from the bath, the same change of the electric power, of the bath's heat of freezing).
    Such hypotheses are one explanation, named in :func:`.naming.naming_order`."""
    if a.key == b.key:
        return True
    x, u = generic_points()
    with np.errstate(all="ignore"):
        sa, sb = (np.nan_to_num(h.sensitivity(model, x, u)) for h in (a, b))
    return proportional(sa, sb)
