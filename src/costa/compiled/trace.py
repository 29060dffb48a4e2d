"""The cell model's array code traced for one row, into straight-line C.

The model is written once over an array namespace (:class:`~costa.physics.CellVariables`
reads ``xp`` from its arrays).  Here its arrays are symbols of one row: a :class:`Symbol`
stands for one number, a :class:`Row` for a row's vector (the eight states, the five
inputs, a hypothesis' coefficients), and every operation the model performs on them is
recorded as one operation of a :class:`Program`.  Constants are folded by Python as the
numpy code folds them, and each operation is recorded as numpy computes it on an array
(``a ** 2`` squares, ``a ** 0.5`` takes the square root, ``a ** -1`` the reciprocal,
other powers call ``pow``), so that the compiled line rounds as the array code does.
Identical operations are recorded once.

A program is written as C (:meth:`Program.c_lines`), and so are its derivatives along D
directions (:meth:`Program.dual_lines`, forward mode): each value's tangent is an array
of D numbers, and each operation's tangent rule reuses the value it computed (the
derivative of ``pow(a, c)`` is ``c pow(a, c) / a``), so a direction costs a few
multiply-adds per operation and no further ``exp`` or ``pow``.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable, Sequence
from dataclasses import dataclass

__all__ = ["NAMESPACE", "Program", "Row", "Symbol", "literal"]


@dataclass(frozen=True)
class _Operation:
    """``name = operator(arguments)``; a call writes ``results`` values to the array ``name``."""

    name: str
    operator: str
    arguments: tuple
    results: int = 1


def literal(value) -> str:
    """A symbol's name, or a constant written so that it reads back to the same double."""
    if isinstance(value, Symbol):
        return value.name
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(
            f"the model computes with a {type(value).__name__} while compiled: only numbers and the row's "
            "states, inputs and parameters can enter a compiled kernel"
        )
    value = float(value)
    if math.isnan(value):
        return "NAN"
    if math.isinf(value):
        return "INFINITY" if value > 0 else "-INFINITY"
    return repr(value)


_C = {
    "add": "{0} + {1}",
    "sub": "{0} - {1}",
    "mul": "{0} * {1}",
    "div": "{0} / {1}",
    "neg": "-{0}",
    "pow": "pow({0}, {1})",
    "sqrt": "sqrt({0})",
    "recip": "1.0 / {0}",
    "exp": "exp({0})",
    "log": "log({0})",
    "fabs": "fabs({0})",
}


class Program:
    """Operations on a row's numbers, each defining one new name; identical operations share a name.

    ``inputs``: the names a caller defines (the function's arguments)."""

    def __init__(self, inputs: Sequence[str] = ()):
        self.inputs = tuple(inputs)
        self.operations: list[_Operation] = []
        self._names: dict[tuple, str] = {}

    def symbol(self, name: str) -> Symbol:
        return Symbol(self, name)

    def emit(self, operator: str, *arguments) -> Symbol:
        """The symbol of ``operator(arguments)``, recorded unless an identical operation was."""
        key = (operator, tuple(literal(a) for a in arguments))
        name = self._names.get(key)
        if name is None:
            name = f"t{len(self.operations)}"
            self.operations.append(_Operation(name, operator, tuple(arguments)))
            self._names[key] = name
        return Symbol(self, name)

    def call(self, function: str, arguments: Sequence, results: int) -> list[Symbol]:
        """The symbols of the ``results`` values one call of ``function`` (another program written as C,
        taking these arguments) writes to its last argument."""
        name = f"t{len(self.operations)}"
        self.operations.append(_Operation(name, function, tuple(arguments), results))
        return [Symbol(self, f"{name}[{i}]") for i in range(results)]

    def pruned(self, results: Sequence) -> Program:
        """This program without the operations none of ``results`` depends on."""
        needed = {r.name.split("[")[0] for r in results if isinstance(r, Symbol)}
        kept = []
        for op in reversed(self.operations):
            if op.name in needed:
                kept.append(op)
                needed.update(a.name.split("[")[0] for a in op.arguments if isinstance(a, Symbol))
        program = Program(self.inputs)
        program.operations = kept[::-1]
        return program

    def dependencies(self, inputs: Sequence[str], results: Sequence) -> tuple[int, int, int]:
        """How many of the ``inputs`` each value depends on, added up over the values and over the
        ``results`` (the partial derivatives forward mode by inputs computes, and the terms of the
        results' products with the inputs' tangents), and how many values depend on any (those
        forward mode by directions differentiates)."""
        depends: dict[str, frozenset[str]] = {name: frozenset([name]) for name in inputs}
        for op in self.operations:
            reads = (depends.get(a.name.split("[")[0], frozenset()) for a in op.arguments if isinstance(a, Symbol))
            depends[op.name] = frozenset().union(*reads)
        values = [depends[op.name] for op in self.operations]
        read = [depends.get(r.name, frozenset()) for r in results if isinstance(r, Symbol)]
        return sum(len(d) for d in values), sum(len(d) for d in read), sum(1 for d in values if d)

    @property
    def calls(self) -> bool:
        """Whether the program calls another function."""
        return any(op.operator not in _C for op in self.operations)

    def c_lines(self) -> list[str]:
        """The program as C statements."""
        return [_c_line(op) for op in self.operations]

    def dual_lines(
        self, seeded: Callable[[str], str | None], dual: Callable[[str], str]
    ) -> tuple[list[str], Callable[[object], str | None]]:
        """The program as C statements with every value's tangent ``d_<name>[D]`` beside it (forward
        mode, D directions: the macro ``D``), and the C array of any value's tangent (None: constant).
        ``seeded(name)`` is the C array of an input's tangent (None: an input without one); a call of a
        function ``f`` calls ``dual(f)`` instead, taking the arguments, an array of pointers to their
        tangents (``ZERO``: none) and writing the results, then their tangents."""
        tangent = {name: array for name in self.inputs if (array := seeded(name)) is not None}

        def of(value) -> str | None:
            return tangent.get(value.name) if isinstance(value, Symbol) else None

        lines = []
        for op in self.operations:
            if op.operator not in _C:
                args, incoming = [literal(a) for a in op.arguments], f"a_{op.name}"
                pointers = ", ".join(of(a) or "ZERO" for a in op.arguments)
                lines.append(f"const double *{incoming}[{len(args)}] = {{{pointers}}};")
                lines.append(f"double {op.name}[{op.results}], d_{op.name}[{op.results} * D];")
                lines.append(f"{dual(op.operator)}({', '.join([*args, incoming, op.name, 'd_' + op.name])});")
                tangent.update({f"{op.name}[{i}]": f"(d_{op.name} + {i} * D)" for i in range(op.results)})
                continue
            lines.append(_c_line(op))
            operands = [f"{of(a)}[j]" if of(a) else None for a in op.arguments]
            if any(operands):
                factors, expression = _tangent(op, operands)
                lines += [f"const double {name} = {value};" for name, value in factors]
                lines.append(f"double d_{op.name}[D]; FOR(j) d_{op.name}[j] = {expression};")
                tangent[op.name] = f"d_{op.name}"
        return lines, of

    def partial_lines(self, inputs: Sequence[str]) -> tuple[list[str], Callable[[object], dict[str, str]]]:
        """C statements for every value's partial derivatives with respect to the ``inputs`` it depends
        on (sparse: a value that reads three states has three), after :meth:`c_lines`, and each
        value's partials {input: C expression} (empty: constant in them).  For a program without
        calls: a function's Jacobian with respect to its arguments."""
        partials: dict[str, dict[str, str]] = {name: {name: "1.0"} for name in inputs}

        def of(value) -> dict[str, str]:
            return partials.get(value.name, {}) if isinstance(value, Symbol) else {}

        lines = []
        for op in self.operations:
            if op.operator not in _C:
                raise ValueError(f"partial derivatives through a call of {op.operator!r}: differentiate the callee")
            args = [of(a) for a in op.arguments]
            found: dict[str, str] = {}
            emitted: set[str] = set()
            for name in dict.fromkeys(k for d in args for k in d):
                factors, expression = _tangent(op, [d.get(name) for d in args])
                lines += [f"const double {factor} = {value};" for factor, value in factors if factor not in emitted]
                emitted.update(factor for factor, _ in factors)
                found[name] = f"q_{op.name}_{name}"
                lines.append(f"const double {found[name]} = {expression};")
            partials[op.name] = found
        return lines, of


def _c_line(op: _Operation) -> str:
    args = [literal(a) for a in op.arguments]
    if op.operator in _C:
        return f"const double {op.name} = {_C[op.operator].format(*args)};"
    return f"double {op.name}[{op.results}]; {op.operator}({', '.join([*args, op.name])});"


def _tangent(op: _Operation, d: list[str | None]) -> tuple[list[tuple[str, str]], str]:
    """The tangent of one operation from its arguments' tangents ``d`` (C expressions; None: constant):
    scalar factors it needs (name, C expression) and its expression."""
    a = [literal(x) for x in op.arguments]
    t, f = op.name, f"f_{op.name}"
    da, db = (d + [None])[:2]
    match op.operator:
        case "add":
            return [], " + ".join(x for x in (da, db) if x)
        case "sub":
            return [], (f"{da} - {db}" if da and db else da or f"-{db}")
        case "mul":
            terms = [f"{da} * {a[1]}" if da else None, f"{a[0]} * {db}" if db else None]
            return [], " + ".join(x for x in terms if x)
        case "div":
            if db is None:
                return [], f"{da} / {a[1]}"
            return [], (f"({da} - {t} * {db}) / {a[1]}" if da else f"-{t} * {db} / {a[1]}")
        case "neg":
            return [], f"-{da}"
        case "pow":
            factors = [(f"{f}a", f"{a[1]} * {t} / {a[0]}"), (f"{f}b", f"{t} * log({a[0]})")]
            used = [(factor, x) for factor, x in zip(factors, (da, db), strict=True) if x]
            return [factor for factor, _ in used], " + ".join(f"{name} * {x}" for (name, _), x in used)
        case "sqrt":
            return [(f, f"0.5 / {t}")], f"{f} * {da}"
        case "recip":
            return [(f, f"-{t} * {t}")], f"{f} * {da}"
        case "exp":
            return [], f"{t} * {da}"
        case "log":
            return [], f"{da} / {a[0]}"
        case "fabs":
            return [(f, f"({a[0]} < 0.0 ? -1.0 : 1.0)")], f"{f} * {da}"
    raise ValueError(f"no tangent rule for {op.operator!r}")


class Symbol:
    """One number of a row, as a name in a :class:`Program`."""

    __slots__ = ("program", "name")
    # numpy hands ``ndarray op Symbol`` to the symbol, which refuses it (a value not passed to the kernel)
    __array_ufunc__ = None
    shape: tuple[int, ...] = ()
    ndim = 0

    def __init__(self, program: Program, name: str):
        self.program, self.name = program, name

    def __array_namespace__(self, api_version=None):
        return NAMESPACE

    def _binary(self, other, operator: str, reflected: bool = False):
        if isinstance(other, Row):
            return NotImplemented
        literal(other)  # refuses anything but a number
        return self.program.emit(operator, *((other, self) if reflected else (self, other)))

    def __add__(self, other):
        return self._binary(other, "add")

    def __radd__(self, other):
        return self._binary(other, "add", True)

    def __sub__(self, other):
        return self._binary(other, "sub")

    def __rsub__(self, other):
        return self._binary(other, "sub", True)

    def __mul__(self, other):
        return self._binary(other, "mul")

    def __rmul__(self, other):
        return self._binary(other, "mul", True)

    def __truediv__(self, other):
        return self._binary(other, "div")

    def __rtruediv__(self, other):
        return self._binary(other, "div", True)

    def __neg__(self):
        return self.program.emit("neg", self)

    def __pos__(self):
        return self

    def __abs__(self):
        return self.program.emit("fabs", self)

    def __pow__(self, exponent):
        if isinstance(exponent, Symbol):
            return self.program.emit("pow", self, exponent)
        literal(exponent)
        exponent = float(exponent)
        # numpy's fast paths for an array raised to a Python number, and pow's exact cases
        if exponent == 1.0:
            return self
        if exponent == 0.0:
            return 1.0
        if exponent == 2.0:
            return self.program.emit("mul", self, self)
        if exponent == 0.5:
            return self.program.emit("sqrt", self)
        if exponent == -1.0:
            return self.program.emit("recip", self)
        return self.program.emit("pow", self, exponent)

    def __rpow__(self, base):
        literal(base)
        return self.program.emit("pow", float(base), self)

    def __bool__(self):
        raise TypeError("a compiled kernel cannot branch on a row's value (use the array namespace's functions)")


class Row:
    """A row's vector of numbers (n,), as symbols or constants; indexed as the batched array is:
    ``x[..., i]``, ``theta[:, k]`` and ``x[i]`` all pick the i-th number of the row."""

    __array_ufunc__ = None
    ndim = 1

    def __init__(self, items: Sequence):
        self.items = list(items)

    @property
    def shape(self) -> tuple[int, ...]:
        return (len(self.items),)

    def __array_namespace__(self, api_version=None):
        return NAMESPACE

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, key):
        if isinstance(key, tuple):
            picked = [k for k in key if k is not Ellipsis and k != slice(None)]
            if len(picked) != 1:
                raise IndexError(f"a compiled row is indexed by one position, got {key!r}")
            key = picked[0]
        return self.items[key]

    def _map(self, other, operation):
        if isinstance(other, Row):
            if len(other) != len(self):
                raise ValueError(f"rows of {len(self)} and {len(other)} numbers")
            return Row([operation(a, b) for a, b in zip(self.items, other.items, strict=True)])
        return Row([operation(a, other) for a in self.items])

    def __add__(self, other):
        return self._map(other, lambda a, b: a + b)

    def __radd__(self, other):
        return self._map(other, lambda a, b: b + a)

    def __sub__(self, other):
        return self._map(other, lambda a, b: a - b)

    def __rsub__(self, other):
        return self._map(other, lambda a, b: b - a)

    def __mul__(self, other):
        return self._map(other, lambda a, b: a * b)

    def __rmul__(self, other):
        return self._map(other, lambda a, b: b * a)

    def __truediv__(self, other):
        return self._map(other, lambda a, b: a / b)

    def __rtruediv__(self, other):
        return self._map(other, lambda a, b: b / a)

    def __neg__(self):
        return Row([-a for a in self.items])


def _unary(function: str):
    def apply(a):
        if isinstance(a, Row):
            return Row([apply(item) for item in a.items])
        if isinstance(a, Symbol):
            return a.program.emit(function, a)
        return getattr(math, function)(float(a))

    apply.__name__ = function
    return apply


class _Namespace:
    """The array functions the model calls (``v.xp.exp`` ...), for a traced row."""

    __name__ = "costa.compiled.trace"

    exp = staticmethod(_unary("exp"))
    log = staticmethod(_unary("log"))
    sqrt = staticmethod(_unary("sqrt"))

    @staticmethod
    def full_like(a, fill_value):
        return float(fill_value)

    @staticmethod
    def ones_like(a):
        return 1.0

    @staticmethod
    def zeros_like(a):
        return 0.0

    @staticmethod
    def stack(items, axis=0):
        if axis not in (0, -1):
            raise ValueError(f"a compiled row stacks along its one axis, not axis {axis}")
        return Row(items)

    def __getattr__(self, name: str):
        raise AttributeError(f"compiled kernels do not support the array function {name!r}")


NAMESPACE = _Namespace()
