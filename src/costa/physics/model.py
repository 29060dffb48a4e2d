"""The cell model: its parts assembled into eight balances.

Balances (paper numbering, q = the quantities computed by the parts, see
:mod:`costa.physics.parts`):

- ledge mass      dx1/dt = w
- Al2O3 mass      dx2/dt = u1 - r_Al2O3
- AlF3 mass       dx3/dt = u3 - r_AlF3
- cryolite mass   dx4/dt = -w + r_cry
- metal mass      dx5/dt = r_Al - u4
- bath energy     dx6/dt = alpha/m (P_el - Q_bath_ledge + Q_bath_freeze)
- ledge energy    dx7/dt = beta/x1 (Q_front_ledge - Q_ledge_wall + Q_ledge_freeze)
- wall energy     dx8/dt = k17 (Q_ledge_wall - Q_wall_ambient)

Extra :class:`BalanceTerm` s add flows in physical units to any balance: kg/s to a
mass balance, W to an energy balance; :class:`~costa.physics.properties.PropertyCorrection` s
change a physical property that several constants share; :class:`InputCorrection` s say
that an input reaching the cell is not the logged one (a feeder delivering 92 % of its
command).  This is how hidden effects are made and how discovered corrections are put back.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from ..variables import INPUTS, MEANING
from .cell import Array, CellVariables
from .parameters import CellParameters, authors_code_parameters, parameters_from_config
from .parts import (
    PART_ORDER,
    Part,
    PartFunction,
    authors_code_parts,
    constant_part,
    paper_printed_parts,
)
from .properties import PropertyCorrection

__all__ = [
    "BALANCES",
    "BalanceTerm",
    "CellModel",
    "InputCorrection",
    "ablated_model",
    "model_from_config",
    "true_model",
]

#: balance name -> (state it drives, unit of the flows it adds up)
BALANCES: dict[str, tuple[str, str]] = {
    "ledge_mass": ("x1", "kg/s"),
    "alumina_mass": ("x2", "kg/s"),
    "alf3_mass": ("x3", "kg/s"),
    "cryolite_mass": ("x4", "kg/s"),
    "metal_mass": ("x5", "kg/s"),
    "bath_energy": ("x6", "W"),
    "ledge_energy": ("x7", "W"),
    "wall_energy": ("x8", "W"),
}


@dataclass(frozen=True)
class BalanceTerm:
    """A flow added to one or more balances: ``targets[balance] * fn(...)``.

    ``unit`` must be that of every target balance ("kg/s" or "W"); a flow that
    moves mass from one balance to another has two targets of opposite sign.
    """

    name: str
    formula: str
    unit: str
    targets: Mapping[str, float]
    fn: PartFunction

    def __post_init__(self):
        for balance in self.targets:
            if balance not in BALANCES:
                raise ValueError(f"term {self.name!r}: unknown balance {balance!r}; known: {list(BALANCES)}")
            if BALANCES[balance][1] != self.unit:
                raise ValueError(
                    f"term {self.name!r} is in {self.unit} but balance {balance!r} adds up {BALANCES[balance][1]}"
                )


@dataclass(frozen=True)
class InputCorrection:
    """The input that reaches the cell: ``input`` delivered = logged x (1 + fn(v)).

    ``fn`` is a relative gain [-]; it reads the states and the logged inputs, and the
    model uses the delivered input wherever it reads this one (every part and balance).
    """

    input: str
    formula: str
    fn: Callable[[CellVariables], Array]

    def __post_init__(self):
        if self.input not in INPUTS:
            raise ValueError(f"unknown input {self.input!r}; known: {list(INPUTS)}")


class _Recorder:
    """Passes attribute and item reads through to ``target`` and records their names in ``seen``."""

    def __init__(self, target, seen: set[str]):
        self._target, self._seen = target, seen

    def __getattr__(self, name: str):
        self._seen.add(name)
        return getattr(self._target, name)

    def __getitem__(self, key: str):
        self._seen.add(key)
        return self._target[key]


@dataclass(frozen=True)
class CellModel:
    """A cell model: constants, one :class:`Part` per quantity, extra balance terms."""

    name: str
    params: CellParameters
    parts: Mapping[str, Part]
    terms: tuple[BalanceTerm, ...] = field(default_factory=tuple)
    properties: tuple[PropertyCorrection, ...] = field(default_factory=tuple)
    inputs: tuple[InputCorrection, ...] = field(default_factory=tuple)

    def __post_init__(self):
        if tuple(self.parts) != PART_ORDER:
            raise ValueError(f"model {self.name!r}: parts must be exactly {PART_ORDER} in order")

    # ----------------------------------------------------------- evaluation
    def _variables(self, x: Array, u: Array) -> CellVariables:
        """The cell variables with the inputs as delivered (where an input correction applies)."""
        v = CellVariables(x, u)
        if not self.inputs:
            return v
        columns = [v.u1, v.u2, v.u3, v.u4, v.u5]
        for correction in self.inputs:
            i = INPUTS.index(correction.input)
            columns[i] = columns[i] * (1 + correction.fn(v))
        return CellVariables(x, v.xp.stack(columns, axis=-1))

    def _parameters(self, v: CellVariables) -> CellParameters:
        """The constants at these samples: rescaled where a property correction applies."""
        if not self.properties:
            return self.params
        changed: dict[str, Array] = {}
        for correction in self.properties:
            factor = 1 + correction.fn(v)
            for name, exponent in correction.property.exponents.items():
                changed[name] = changed.get(name, getattr(self.params, name)) * factor**exponent
        return dataclasses.replace(self.params, **changed)

    def _evaluate(self, v: CellVariables) -> tuple[CellParameters, dict[str, Array]]:
        k = self._parameters(v)
        q: dict[str, Array] = {}
        for name, part in self.parts.items():
            q[name] = part(v, k, q)
        return k, q

    def _flows(self, v: CellVariables, k: CellParameters, q: Mapping[str, Array]) -> dict[str, Array]:
        flows = {
            "ledge_mass": q["freezing_rate"],
            "alumina_mass": v.u1 - q["alumina_consumption"],
            "alf3_mass": v.u3 - q["alf3_neutralisation"],
            "cryolite_mass": -q["freezing_rate"] + q["cryolite_formation"],
            "metal_mass": q["metal_production"] - v.u4,
            "bath_energy": q["electric_power"] - q["bath_ledge_heat"] + q["bath_freezing_heat"],
            "ledge_energy": q["front_ledge_heat"] - q["ledge_wall_heat"] + q["ledge_freezing_heat"],
            "wall_energy": q["ledge_wall_heat"] - q["wall_ambient_heat"],
        }
        for term in self.terms:
            value = term.fn(v, k, q)
            for balance, coefficient in term.targets.items():
                flows[balance] = flows[balance] + coefficient * value
        return flows

    def quantities(self, x: Array, u: Array) -> dict[str, Array]:
        """Every part's value at states x (..., 8) and inputs u (..., 5)."""
        return self._evaluate(self._variables(x, u))[1]

    def delivered_inputs(self, x: Array, u: Array) -> Array:
        """The inputs (..., 5) as they reach the cell: the logged u where no input correction applies."""
        return self._variables(x, u).u

    def reads(self, x: Array, u: Array) -> dict[str, frozenset[str]]:
        """What each part reads directly, recorded by evaluating it at states x and inputs u:
        cell variables (``x6``, ``c2``, ``u2``, ...), constants (``k1``, ...) and earlier parts."""
        v = self._variables(x, u)
        k = self._parameters(v)
        q: dict[str, Array] = {}
        reads = {}
        for name, part in self.parts.items():
            seen: set[str] = set()
            q[name] = part(_Recorder(v, seen), _Recorder(k, seen), _Recorder(q, seen))
            reads[name] = frozenset(seen)
        return reads

    def flow_reads(self, x: Array, u: Array) -> frozenset[str]:
        """The parts (and cell variables, constants) the balances' flows read directly, recorded by
        evaluating them at states x and inputs u."""
        v = self._variables(x, u)
        k, q = self._evaluate(v)
        seen: set[str] = set()
        self._flows(_Recorder(v, seen), _Recorder(k, seen), _Recorder(q, seen))
        return frozenset(seen)

    def balance_flows(self, x: Array, u: Array) -> dict[str, Array]:
        """The net flow into each balance, in kg/s or W (before heat capacities)."""
        v = self._variables(x, u)
        return self._flows(v, *self._evaluate(v))

    def rhs(self, x: Array, u: Array) -> Array:
        """dx/dt (..., 8) in kg/s and degC/s."""
        v = self._variables(x, u)
        k, q = self._evaluate(v)
        f = self._flows(v, k, q)
        rates = [f[b] for b in ("ledge_mass", "alumina_mass", "alf3_mass", "cryolite_mass", "metal_mass")]
        rates += [
            k.alpha / v.m * f["bath_energy"],
            k.beta / v.x1 * f["ledge_energy"],
            k.k17 * f["wall_energy"],
        ]
        return v.xp.stack(rates, axis=-1)

    def state_rate_per_flow(self, x: Array, u: Array) -> Array:
        """d(dx_i/dt)/d(flow into balance i) (..., 8): 1 for masses, alpha/m, beta/x1, k17."""
        v = self._variables(x, u)
        one = v.xp.ones_like(v.x1)
        k = self._parameters(v)
        return v.xp.stack([one] * 5 + [k.alpha / v.m, k.beta / v.x1, k.k17 * one], axis=-1)

    # ------------------------------------------------------------- variants
    def with_part(self, name: str, part: Part, model_name: str | None = None) -> CellModel:
        """This model with one part replaced."""
        if name not in self.parts:
            raise ValueError(f"unknown part {name!r}; known: {list(self.parts)}")
        parts = dict(self.parts)
        parts[name] = part
        return dataclasses.replace(self, parts=parts, name=model_name or f"{self.name}+{name}")

    def with_terms(self, *terms: BalanceTerm, model_name: str | None = None) -> CellModel:
        """This model with extra flows added to its balances."""
        names = [t.name for t in terms]
        return dataclasses.replace(
            self, terms=self.terms + tuple(terms), name=model_name or f"{self.name}+{'+'.join(names)}"
        )

    def with_property(self, correction: PropertyCorrection, model_name: str | None = None) -> CellModel:
        """This model with one physical property changed (see :mod:`costa.physics.properties`)."""
        return dataclasses.replace(
            self,
            properties=(*self.properties, correction),
            name=model_name or f"{self.name}+{correction.property.name}",
        )

    def with_input(self, correction: InputCorrection, model_name: str | None = None) -> CellModel:
        """This model with one input delivered differently from its log."""
        return dataclasses.replace(
            self, inputs=(*self.inputs, correction), name=model_name or f"{self.name}+{correction.input} delivered"
        )

    def describe(self) -> str:
        """The model as readable equations, one quantity per line."""
        lines = [f"model {self.name}"]
        lines += [f"  {p.symbol} = {p.formula}  [{p.unit}]   ({p.name})" for p in self.parts.values()]
        for t in self.terms:
            where = ", ".join(f"{c:+g} x {b}" for b, c in t.targets.items())
            lines.append(f"  + {t.name} = {t.formula}  [{t.unit}]  into {where}")
        for c in self.properties:
            scaled = ", ".join(f"{name}^{exponent:g}" for name, exponent in c.property.exponents.items())
            lines.append(f"  * {c.property.name} x (1 + {c.formula})   (rescales {scaled})")
        for c in self.inputs:
            gain = f"(1 + {c.formula})".replace("+ -", "- ")
            lines.append(f"  {c.input} delivered = {c.input} x {gain}   ({MEANING[c.input]}, as logged)")
        return "\n".join(lines)


def true_model(params: CellParameters | None = None, variant: str = "authors_code") -> CellModel:
    """The full model that generates the data (default: as the authors coded it)."""
    parts = {"authors_code": authors_code_parts, "paper_printed": paper_printed_parts}
    if variant not in parts:
        raise ValueError(f"unknown equations variant {variant!r}; known: {sorted(parts)}")
    model = CellModel(f"true[{variant}]", params or authors_code_parameters(), parts[variant]())
    if variant == "paper_printed":
        model = model.with_terms(_printed_ledge_wall_term(), model_name=model.name)
    return model


def _printed_ledge_wall_term() -> BalanceTerm:
    """The printed ledge balance has the wall heat flow without the area k9.

    Printed dx7/dt uses (x7 - x8)/(k14 + k15 k0 x1) = Q_ledge_wall / k9, so it equals
    the coded balance plus (1 - 1/k9) Q_ledge_wall.
    """

    def fn(v, k, q):
        return (1 - 1 / k.k9) * q["ledge_wall_heat"]

    return BalanceTerm("printed_missing_k9", "(1 - 1/k9) Q_ledge_wall", "W", {"ledge_energy": 1.0}, fn)


def ablated_model(base: CellModel | None = None, liquidus_temperature: float = 968.0) -> CellModel:
    """The paper's PBM: ``base`` (default: the true model) with g1 fixed."""
    base = base or true_model()
    part = constant_part(base.parts["liquidus_temperature"], liquidus_temperature)
    return base.with_part("liquidus_temperature", part, model_name=f"ablated[g1={liquidus_temperature:g}]")


def model_from_config(physics: Mapping) -> tuple[CellModel, CellModel]:
    """(true model, ablated PBM) from the ``physics`` section of the config."""
    params = parameters_from_config(physics["constants"], physics.get("overrides"), physics.get("cell"))
    true = true_model(params, physics["equations"])
    return true, ablated_model(true, physics["ablated_liquidus_temperature"])
