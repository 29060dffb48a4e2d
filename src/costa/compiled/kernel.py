"""Discrete-time systems traced to C and compiled, for batches of rows.

A :class:`CompiledSystem` is a state x (NX,) advanced by ``step(x, u)`` and read by
``sensors(x, u)``, both written as array code over one row (:mod:`.trace`), with values
read at evaluation time (:class:`Parameters`: a hypothesis' coefficients, a random walk's
delta).  It is traced into C functions with their duals (values and derivatives along D
directions, forward mode), surrounded by loops over rows and steps and by an extended
Kalman filter and Rauch-Tung-Striebel smoother (:meth:`CompiledSystem.smooth`), and
compiled with the C compiler (``CC``, else ``cc``) into a shared library named by a hash of
its source: a system of the same structure and constants compiles once, for this process
and later ones (:func:`kernel_cache`).  :class:`CompiledModel` is the cell model's: one RK4
step of ``dt`` of its rates, and its measured channels (:func:`costa.observe.observe`).  A call's
rows are shared among ``OMP_NUM_THREADS`` threads (a workflow job's own threads; else one): each
row is computed alone, so the numbers do not depend on how many.

The compiled step rounds as numpy's step of the same model does, operation for operation
(:mod:`.trace`; no contracted multiply-adds), with the same C library's ``exp`` and ``pow``:
its values are numpy's to the bit, but where numpy's own vector ``exp`` or ``pow`` differ
from the C library's in the last bit (some CPUs' vector units).  Derivatives are exact (to
rounding) where finite differences were not, and cost a few multiply-adds per operation and
direction, where a difference costs a whole evaluation.

The smoother augments the state with NA further states a (z = (x, a), L = NX + NA), held
constant or as random walks, that the system reads linearly: its parameters are p = M a, M
(NP, NA) given per row (a hypothesis' delta scaled, or its coefficients themselves).
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import platform
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from ..integrate import rk4_step
from ..observe import observe
from ..physics import CellModel
from .trace import Program, Row, literal

__all__ = ["CompiledModel", "CompiledSystem", "Parameters", "Smoothed", "compile_side_by_side", "kernel_cache"]

#: the compiler's options: -O1 with the loop vectorizer (compiles in 60 % of -O2's time, runs as fast or
#: faster, the same bits), no contraction of a * b + c into one rounding, no vector ISA beyond the
#: platform's baseline, ``errno`` not set by the math functions (their values are the same)
CFLAGS = ("-O1", "-ftree-vectorize", "-std=c99", "-fPIC", "-shared", "-pthread", "-ffp-contract=off", "-fno-math-errno")
#: the C source of the loops and the smoother, beside this module
TEMPLATE = Path(__file__).with_name("system.c")

Traced = Callable[[Program, Row, Row], Row]


class Parameters:
    """Values a model reads when it is evaluated: one per row (``width`` None) or ``width`` per row.

    Pass it as the ``source`` of a model that reads it (``Hypothesis.parametrised``, ``.driven``);
    numpy code sets :attr:`value` (rows,) or (rows, width) before evaluating the model, a compiled
    kernel takes the values as an argument (:class:`CompiledSystem`)."""

    def __init__(self, width: int | None = None):
        self.width = width
        self.value = None

    def __call__(self):
        return self.value

    @property
    def size(self) -> int:
        """Numbers per row."""
        return 1 if self.width is None else self.width


def kernel_cache() -> Path:
    """Where compiled kernels are kept: ``COSTA_KERNEL_CACHE``, else ``~/.cache/costa/kernels``."""
    return Path(os.environ.get("COSTA_KERNEL_CACHE") or Path.home() / ".cache" / "costa" / "kernels")


def _signature(arguments: Sequence[str], *pointers: str) -> str:
    return ", ".join([*(f"const double {a}" for a in arguments), *pointers])


def _function(name: str, arguments: Sequence[str], program: Program, results: Sequence) -> str:
    """A C function of the traced ``program`` writing ``results`` to its last argument."""
    body = "".join(f"    {line}\n" for line in program.c_lines())
    written = "".join(f"    out[{i}] = {literal(r)};\n" for i, r in enumerate(results))
    return f"static void {name}({_signature(arguments, 'double *restrict out')})\n{{\n{body}{written}}}\n"


def _dual(
    name: str, arguments: Sequence[str], program: Program, results: Sequence, differentiable, directions: int
) -> str:
    """``name``'s dual ``name_d``: the results and their tangents along D = ``directions`` directions,
    from pointers to the arguments' tangents (D numbers each).  A program is differentiated direction
    by direction (:meth:`.trace.Program.dual_lines`), or where that costs more and it makes no calls,
    by its inputs (:meth:`.trace.Program.partial_lines`: its Jacobian, sparse, then one product per
    result): the Jacobian of a value that reads three states has three entries, its tangent D."""
    partials, terms, values = program.dependencies(differentiable, results)
    if program.calls or values * directions <= partials + terms * directions:
        lines, tangent = program.dual_lines(
            lambda a: f"din[{arguments.index(a)}]" if a in differentiable else None, lambda f: f"{f}_d"
        )
        products = [f"{tangent(r)}[j]" if tangent(r) else "0.0" for r in results]
    else:
        partials, partial = program.partial_lines(differentiable)
        lines = program.c_lines() + partials
        products = [
            " + ".join(f"{q} * din[{arguments.index(a)}][j]" for a, q in partial(r).items()) or "0.0" for r in results
        ]
    body = "".join(f"    {line}\n" for line in lines)
    written = "".join(
        f"    out[{i}] = {literal(r)};\n    FOR(j) dout[{i} * D + j] = {product};\n"
        for i, (r, product) in enumerate(zip(results, products, strict=True))
    )
    pointers = ("const double *const *din", "double *restrict out", "double *restrict dout")
    return f"static void {name}_d({_signature(arguments, *pointers)})\n{{\n{body}{written}}}\n"


def _library(source: str, derivatives: bool) -> ctypes.CDLL:
    """The shared library of ``source``, compiled into :func:`kernel_cache` under the hash of its text,
    the machine's kind and the compiler (the C file kept beside it)."""
    compiler = shutil.which(os.environ.get("CC") or "cc")
    if compiler is None:
        raise RuntimeError(
            f"discovery compiles the cell model to C and found no C compiler ({os.environ.get('CC') or 'cc'}): "
            "install gcc or clang, or name one in CC"
        )
    # a cache shared by machines of other kinds (a cluster's home folder) keeps each kind's own library
    built_by = f"{platform.machine()} {os.path.realpath(compiler)} {' '.join(CFLAGS)}"
    name = "costa_kernel_" + hashlib.sha256(f"{built_by}\n{source}".encode()).hexdigest()[:24]
    folder = kernel_cache()
    folder.mkdir(parents=True, exist_ok=True)
    library = folder / f"{name}.so"
    if not library.exists():
        with tempfile.TemporaryDirectory(dir=folder) as work:
            c_file, built = Path(work) / f"{name}.c", Path(work) / f"{name}.so"
            c_file.write_text(source)
            done = subprocess.run(
                [compiler, *CFLAGS, "-o", str(built), str(c_file), "-lm"], capture_output=True, text=True
            )
            if done.returncode != 0:
                raise RuntimeError(f"compiling a cell model's kernel failed ({compiler}):\n{done.stderr[-2000:]}")
            os.replace(c_file, folder / c_file.name)
            os.replace(built, library)  # atomic: a job beside this one sees the whole library or none
    loaded = ctypes.CDLL(str(library))
    pointer, count = ctypes.c_void_p, ctypes.c_long
    loaded.march.argtypes = [count, count, *[pointer] * 5, ctypes.c_int]
    for function in ("step_rows", "sense_rows"):
        getattr(loaded, function).argtypes = [count, *[pointer] * 4]
    loaded.set_threads.argtypes = [ctypes.c_int]
    if derivatives:
        loaded.march_channels_d.argtypes = [count, count, *[pointer] * 9]
        loaded.smooth.argtypes = [count, count, *[pointer] * 7, ctypes.c_int, *[pointer] * 5]
        loaded.smooth.restype = ctypes.c_int
    return loaded


def _threads() -> int:
    """How many threads share a call's rows: ``OMP_NUM_THREADS`` (a workflow job's threads), else 1."""
    value = os.environ.get("OMP_NUM_THREADS", "")
    return max(1, int(value)) if value.isdigit() else 1


def compile_side_by_side(systems: Iterable[CompiledSystem]) -> None:
    """Compile the ``systems`` (made with ``compiled=False``) at once, as many compilers as the job has
    threads: a batch of models then costs about its longest compiles, not their sum."""
    with ThreadPoolExecutor(max_workers=_threads()) as pool:
        list(pool.map(lambda system: system._library, systems))


def _rows(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float)


def _pointers(*arrays: np.ndarray) -> list[int]:
    return [a.ctypes.data for a in arrays]


@dataclass
class Smoothed:
    """What the smoother found, per row n and step k.

    ``mean``, ``std`` (n, K, L): smoothed states and their marginal std (the filter's at the last step,
    (n, 1, L), where only filtered); ``innovation`` (n, K, C): standardised one-step-ahead prediction
    errors of the filter (NaN where the channel was not measured); ``log_likelihood`` (n,): the log
    density of each row's measurements under the system; ``final_cov`` (n, L, L): the covariance at
    the last step, given every measurement.
    """

    mean: np.ndarray
    std: np.ndarray
    innovation: np.ndarray
    log_likelihood: np.ndarray
    final_cov: np.ndarray


class CompiledSystem:
    """``functions`` (name -> f(program, x, u) -> Row, traced in order; "step" and "sensors" are the
    system's, others helpers they call through ``program.call``) of ``states`` numbers x, ``inputs``
    numbers u and the ``parameters``' values, with ``channels`` sensors and ``augmented`` further
    states for the smoother (default: one per parameter number, read as the parameters themselves).
    ``derivatives`` False: the values alone (:meth:`step`, :meth:`sense`, :meth:`march`), compiled
    in a fraction of the time.  ``compiled`` False: traced now, compiled at first use or by
    :func:`compile_side_by_side` with others."""

    def __init__(
        self,
        functions: Mapping[str, Traced],
        states: int,
        inputs: int,
        channels: int,
        parameters: Sequence[Parameters] = (),
        augmented: int | None = None,
        title: str = "a compiled system",
        derivatives: bool = True,
        compiled: bool = True,
    ):
        self.states, self.inputs, self.channels = states, inputs, channels
        self.parameters = tuple(parameters)
        self.size = sum(p.size for p in self.parameters)
        self.augmented = self.size if augmented is None else augmented
        self.directions = states + self.augmented
        self._text, self._derivatives = self._source(functions, title, derivatives), derivatives
        if compiled:
            _ = self._library  # compiled (or found in the cache) now

    @cached_property
    def _library(self) -> ctypes.CDLL:
        loaded = _library(self._text, self._derivatives)
        loaded.set_threads(_threads())
        return loaded

    def _source(self, functions: Mapping[str, Traced], title: str, derivatives: bool) -> str:
        x_names = [f"x{i}" for i in range(self.states)]
        u_names = [f"u{i}" for i in range(self.inputs)]
        p_names = [f"p{i}" for i in range(self.size)]
        arguments = x_names + u_names + p_names

        def traced(function: Traced) -> tuple[Program, list]:
            """``function`` traced with the parameters' values as symbols: its program and results."""
            program = Program(arguments)
            x, u = (Row([program.symbol(n) for n in names]) for names in (x_names, u_names))
            saved = [p.value for p in self.parameters]
            start = 0
            try:
                for p in self.parameters:
                    symbols = [program.symbol(n) for n in p_names[start : start + p.size]]
                    p.value = symbols[0] if p.width is None else Row(symbols)
                    start += p.size
                results = function(program, x, u).items
                return program.pruned(results), results
            finally:
                for p, value in zip(self.parameters, saved, strict=True):
                    p.value = value

        programs = {name: traced(function) for name, function in functions.items()}
        code = [_function(name, arguments, *traced_) for name, traced_ in programs.items()]
        if derivatives:
            code += [
                _dual(name, arguments, *traced_, x_names + p_names, self.directions)
                for name, traced_ in programs.items()
            ]
        sizes = {"NX": self.states, "NU": self.inputs, "NP": self.size, "NA": self.augmented, "NC": self.channels}
        defines = "".join(f"#define {name} {value}\n" for name, value in sizes.items())
        call = ", ".join([*(f"x[{i}]" for i in range(self.states)), *(f"u[{i}]" for i in range(self.inputs))])
        call += "".join(f", p[{i}]" for i in range(self.size))
        template, tail = TEMPLATE.read_text().split("/* --- the system's functions --- */")
        loops = tail if derivatives else tail.split("/* --- derivatives --- */")[0]
        head = f"/* {title} */\n#include <math.h>\n#include <stdlib.h>\n\n{defines}#define ARGS {call}\n"
        return head + template + "\n".join(code) + loops

    def _values(self, rows: int, values: Sequence[np.ndarray]) -> np.ndarray:
        if len(values) != len(self.parameters):
            raise ValueError(f"the system reads {len(self.parameters)} parameter arrays, {len(values)} given")
        columns = [
            np.broadcast_to(np.asarray(v, dtype=float), (rows,) if p.width is None else (rows, p.width)).reshape(
                rows, -1
            )
            for p, v in zip(self.parameters, values, strict=True)
        ]
        return np.ascontiguousarray(np.concatenate(columns, axis=1) if columns else np.zeros((rows, 0)))

    def step(self, x: np.ndarray, u: np.ndarray, *values: np.ndarray) -> np.ndarray:
        """The states (R, NX) one step after x (R, NX) under the inputs u (R, NU)."""
        x, u, p = _rows(x), _rows(u), self._values(len(x), values)
        out = np.empty((len(x), self.states))
        self._library.step_rows(len(x), *_pointers(x, u, p, out))
        return out

    def sense(self, x: np.ndarray, u: np.ndarray, *values: np.ndarray) -> np.ndarray:
        """The channels (R, C) at states x (R, NX) and inputs u (R, NU)."""
        x, u, p = _rows(x), _rows(u), self._values(len(x), values)
        out = np.empty((len(x), self.channels))
        self._library.sense_rows(len(x), *_pointers(x, u, p, out))
        return out

    def march(self, x: np.ndarray, u: np.ndarray, *values: np.ndarray, record: str | None = "channels"):
        """From x (R, NX) over the inputs u (R, S, NU): the channels (R, S, C) (``record`` "channels") or the
        states (R, S, NX) ("states") at each step before it is taken, and the states (R, NX) after the
        last; ``record`` None: those states alone."""
        rows, steps = u.shape[:2]
        width = {"channels": self.channels, "states": self.states, None: 0}[record]
        x, u, p = _rows(x), _rows(u), self._values(rows, values)
        out, end = np.empty((rows, steps, width)), np.empty((rows, self.states))
        recorded = {None: 0, "channels": 1, "states": 2}[record]  # system.c's RECORD_NONE, _CHANNELS, _STATES
        self._library.march(rows, steps, *_pointers(x, u, p, out, end), recorded)
        return end if record is None else (out, end)

    def march_tangents(self, x: np.ndarray, u: np.ndarray, values: np.ndarray, dx: np.ndarray, dp: np.ndarray):
        """:meth:`march` with derivatives: from x (R, NX) with tangents dx (R, NX, D), the parameters'
        values (R, NP) with tangents dp (R, NP, D), over the inputs u (R, S, NU): the channels (R, S, C)
        and their tangents (R, S, C, D) at each step before it is taken, the states (R, NX) after the
        last and their tangents (R, NX, D)."""
        rows, steps = u.shape[:2]
        nx, d, c = self.states, self.directions, self.channels
        x, u, p = _rows(x), _rows(u), _rows(np.broadcast_to(values, (rows, self.size)))
        dx, dp = _rows(np.broadcast_to(dx, (rows, nx, d))), _rows(np.broadcast_to(dp, (rows, self.size, d)))
        out, dout = np.empty((rows, steps, c)), np.empty((rows, steps, c, d))
        end, dend = np.empty((rows, nx)), np.empty((rows, nx, d))
        self._library.march_channels_d(rows, steps, *_pointers(x, u, p, out, end, dx, dp, dout, dend))
        return out, dout, end, dend

    def smooth(
        self,
        y: np.ndarray,
        u: np.ndarray,
        mean0: np.ndarray,
        cov0: np.ndarray,
        process_std: np.ndarray,
        noise_std: np.ndarray,
        mixing: np.ndarray | None = None,
        backward: bool = True,
    ) -> Smoothed:
        """Filter forward, smooth backward (an extended Kalman filter, then Rauch-Tung-Striebel).

        z = (x, a) (L = NX + NA): x advanced by the system, a held (a random walk where its process
        std is not 0) and read as the parameters p = M a, ``mixing`` M (n, NP, NA) (default: the
        identity).  y (n, K, C) with NaN where not measured, u (n, K, NU), the prior of the first state
        ``mean0`` (n, L) and ``cov0`` (n, L, L) or (L, L), the process noise per step ``process_std``
        (L,) or (n, L), the channels' noise ``noise_std`` (C,).  ``backward`` False: the filter only
        (innovations and likelihood; ``mean`` and ``std`` then the filter's at the last step), which
        keeps no history.  A row whose filter meets a singular covariance gets NaN from there, the
        others are unaffected."""
        n, steps = y.shape[:2]
        size, c = self.directions, self.channels
        mixing = np.eye(self.size, self.augmented) if mixing is None else mixing
        y, u = _rows(y), _rows(u)
        mixing = _rows(np.broadcast_to(mixing, (n, self.size, self.augmented)))
        mean0, cov0 = _rows(np.broadcast_to(mean0, (n, size))), _rows(np.broadcast_to(cov0, (n, size, size)))
        q = _rows(np.broadcast_to(np.asarray(process_std, dtype=float) ** 2, (n, size)))
        r = _rows(np.broadcast_to(np.asarray(noise_std, dtype=float) ** 2, (c,)))
        kept = steps if backward else 1
        mean, std = np.empty((n, kept, size)), np.empty((n, kept, size))
        innovation, log_likelihood, final = np.empty((n, steps, c)), np.empty(n), np.empty((n, size, size))
        status = self._library.smooth(
            n, steps, *_pointers(y, u, mixing, mean0, cov0, q, r), int(backward),
            *_pointers(mean, std, innovation, log_likelihood, final),
        )  # fmt: skip
        if status != 0:
            raise MemoryError(f"the smoother could not allocate its history of {steps} steps")
        return Smoothed(mean, std, innovation, log_likelihood, final)


class CompiledModel(CompiledSystem):
    """The cell ``model``'s system: one RK4 step of ``dt`` [s] of its rates, its ``channels``
    (:func:`costa.observe.observe`), for states x (R, 8), inputs u (R, 5) and one array of values per
    :class:`Parameters` the model reads, (R,) or (R, width)."""

    def __init__(
        self,
        model: CellModel,
        dt: float,
        channels: Sequence[str] = (),
        parameters: Sequence[Parameters] = (),
        augmented: int | None = None,
        derivatives: bool = True,
        compiled: bool = True,
    ):
        self.model, self.dt = model, float(dt)

        def rates(program, x, u):
            return model.rhs(x, u)

        def step(program, x, u):
            parameters_ = [program.symbol(f"p{i}") for i in range(self.size)]

            def called(x, u):
                return Row(program.call("rates", [*x.items, *u.items, *parameters_], 8))

            return rk4_step(called, x, u, self.dt)

        def sensors(program, x, u):
            return observe(model, x, u, channels) if channels else Row([])

        self.size = sum(p.size for p in parameters)
        functions = {"rates": rates, "step": step, "sensors": sensors}
        title = f"the cell model: RK4 of dt {self.dt!r} s, channels {list(channels)}"
        super().__init__(functions, 8, 5, len(channels), parameters, augmented, title, derivatives, compiled)
