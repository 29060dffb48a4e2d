"""Simulated cell trajectories: initial conditions, controllers, APRBS excitation, RK4.

One sample per step of ``dt`` seconds: sample k stores (x_k, u_k) where u_k is held
over [k, k+1).  Each step x_{k+1} = RK4(x_k, u_k, dt), then u_{k+1} is computed
from x_{k+1}: P-controllers with a dead zone and a cap on the feeds and the
tapping, plus a random excitation (docs/model.md §4); or, where the settings'
``operation`` is "pot_line", a pot line's controllers (:mod:`costa.pot_line`).  All trajectories of a set
advance together as one array; each draws its randomness from its own stream
(:mod:`costa.seeds`), so the data are bit-identical for the same config.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from functools import partial
from typing import Protocol

import numpy as np

from . import seeds
from .compiled import CompiledModel
from .integrate import rk4_step
from .physics import CellModel
from .pot_line import DAY_S, PotLine, PotLineOperation

__all__ = [
    "Controller",
    "HeldSignal",
    "ImpulseTrain",
    "InitialRanges",
    "Operator",
    "SimulationSettings",
    "Trajectories",
    "draw_excitation",
    "draw_initial_state",
    "simulate",
    "simulate_set",
]

Range = tuple[float, float]


@dataclass(frozen=True)
class Controller:
    """rate = gain * error, 0 below ``min_rate`` (dead zone), at most ``max_rate`` [kg/s]."""

    gain: float
    setpoint: float
    min_rate: float
    max_rate: float

    def rate(self, error: np.ndarray) -> np.ndarray:
        rate = np.maximum(self.gain * error, 0.0)
        rate = np.where(rate < self.min_rate, 0.0, rate)
        return np.minimum(rate, self.max_rate)


@dataclass(frozen=True)
class HeldSignal:
    """APRBS: base + a random offset, redrawn after a random hold.

    Offsets are multiples of ``resolution`` drawn uniformly in ``offset`` (both
    ends included); the offset is 0 until the first switch.
    """

    base: float
    offset: Range
    resolution: float
    hold_steps: tuple[int, int]


@dataclass(frozen=True)
class ImpulseTrain:
    """One-step impulses of a random amplitude [kg/s] at random spacings."""

    amplitude: Range
    resolution: float
    first_steps: tuple[int, int]
    spacing_steps: tuple[int, int]


@dataclass(frozen=True)
class InitialRanges:
    """Uniform ranges of the initial state (integer draws, as the authors' code).

    Masses in kg, temperatures in degC; ``c2_percent``/``c3_percent`` are the
    Al2O3/AlF3 mass fractions of the bath in whole percent.
    """

    x1: tuple[int, int]
    c2_percent: tuple[int, int]
    c3_percent: tuple[int, int]
    x4: tuple[int, int]
    x5: tuple[int, int]
    x6: tuple[int, int]
    x7: tuple[int, int]
    x8: tuple[int, int]


@dataclass(frozen=True)
class SimulationSettings:
    """Everything that defines a simulated data set, besides the model and seed."""

    dt: float
    steps: int
    initial: InitialRanges
    alumina_feed: Controller
    alf3_feed: Controller
    metal_tapping: Controller
    line_current: HeldSignal
    anode_cathode_distance: HeldSignal
    alumina_impulses: ImpulseTrain
    alf3_impulses: ImpulseTrain
    pot_line: PotLine | None = None
    #: how the inputs arise: "excitation" (the paper's controllers and random excitation) or "pot_line"
    operation: str = "excitation"

    @classmethod
    def from_config(cls, sim: Mapping) -> SimulationSettings:
        """From the ``simulation`` section of the validated config."""
        ctrl, exc = sim["controllers"], sim["excitation"]
        return cls(
            dt=float(sim["dt_s"]),
            steps=int(sim["steps"]),
            initial=InitialRanges(**{k: tuple(v) for k, v in sim["initial_conditions"].items()}),
            alumina_feed=Controller(**ctrl["alumina_feed"]),
            alf3_feed=Controller(**ctrl["alf3_feed"]),
            metal_tapping=Controller(**ctrl["metal_tapping"]),
            line_current=_held(exc["line_current"]),
            anode_cathode_distance=_held(exc["anode_cathode_distance"]),
            alumina_impulses=_impulses(exc["alumina_impulses"]),
            alf3_impulses=_impulses(exc["alf3_impulses"]),
            pot_line=PotLine.from_config(sim["pot_line"]) if "pot_line" in sim else None,
        )


def _held(c: Mapping) -> HeldSignal:
    return HeldSignal(c["base"], tuple(c["offset"]), c["resolution"], tuple(c["hold_steps"]))


def _impulses(c: Mapping) -> ImpulseTrain:
    return ImpulseTrain(tuple(c["amplitude"]), c["resolution"], tuple(c["first_steps"]), tuple(c["spacing_steps"]))


@dataclass(frozen=True)
class Trajectories:
    """States x (n, steps, 8) and inputs u (n, steps, 5) of n trajectories."""

    x: np.ndarray
    u: np.ndarray


# ---------------------------------------------------------------- draws
def _uniform_int(rng: np.random.Generator, bounds: Sequence[int]) -> int:
    return int(rng.integers(bounds[0], bounds[1], endpoint=True))


def _quantised(rng: np.random.Generator, bounds: Range, resolution: float) -> float:
    lo, hi = (round(b / resolution) for b in bounds)
    return _uniform_int(rng, (lo, hi)) * resolution


def draw_initial_state(rng: np.random.Generator, ranges: InitialRanges) -> np.ndarray:
    """x0 (8,): x2 and x3 solved so that x2/m = c2 and x3/m = c3 for the drawn x4."""
    x1 = _uniform_int(rng, ranges.x1)
    c2 = _uniform_int(rng, ranges.c2_percent) / 100
    c3 = _uniform_int(rng, ranges.c3_percent) / 100
    x4 = _uniform_int(rng, ranges.x4)
    rest = [_uniform_int(rng, getattr(ranges, name)) for name in ("x5", "x6", "x7", "x8")]
    bath = x4 / (1 - c2 - c3)
    return np.array([x1, c2 * bath, c3 * bath, x4, *rest], dtype=float)


def _held_signal(rng: np.random.Generator, signal: HeldSignal, steps: int) -> np.ndarray:
    values = np.full(steps, float(signal.base))
    k = _uniform_int(rng, signal.hold_steps)
    while k < steps:
        values[k:] = signal.base + _quantised(rng, signal.offset, signal.resolution)
        k += _uniform_int(rng, signal.hold_steps)
    return values


def _impulse_train(rng: np.random.Generator, train: ImpulseTrain, steps: int) -> np.ndarray:
    values = np.zeros(steps)
    k = _uniform_int(rng, train.first_steps)
    while k < steps:
        values[k] = _quantised(rng, train.amplitude, train.resolution)
        k += _uniform_int(rng, train.spacing_steps)
    return values


def draw_excitation(rng: np.random.Generator, settings: SimulationSettings) -> dict[str, np.ndarray]:
    """The random part of the inputs of one trajectory, each (steps,)."""
    n = settings.steps
    return {
        "line_current": _held_signal(rng, settings.line_current, n),
        "anode_cathode_distance": _held_signal(rng, settings.anode_cathode_distance, n),
        "alumina_impulses": _impulse_train(rng, settings.alumina_impulses, n),
        "alf3_impulses": _impulse_train(rng, settings.alf3_impulses, n),
    }


# ------------------------------------------------------------- stepping
class Operator(Protocol):
    """What sets a cell's inputs: u_k (n, 5) from the states x_k (n, 8) at step k, and the heat [W] that
    something the model does not describe takes from each bath over that step (0: nothing)."""

    def inputs(self, x: np.ndarray, k: int) -> np.ndarray: ...

    def bath_heat_taken(self) -> np.ndarray | float: ...


@dataclass(frozen=True)
class Excited:
    """The paper's operation: P-controllers on the feeds and the tapping, plus the random excitation."""

    excitation: Mapping[str, np.ndarray]
    settings: SimulationSettings

    def inputs(self, x: np.ndarray, k: int) -> np.ndarray:
        return _inputs(x, self.excitation, k, self.settings)

    def bath_heat_taken(self) -> float:
        return 0.0


def _inputs(x: np.ndarray, excitation: Mapping[str, np.ndarray], k: int, s: SimulationSettings) -> np.ndarray:
    """u_k (n, 5) from the states x_k (n, 8) and step k of the excitation."""
    bath = x[:, 1] + x[:, 2] + x[:, 3]
    return np.stack(
        [
            s.alumina_feed.rate(s.alumina_feed.setpoint - x[:, 1] / bath) + excitation["alumina_impulses"][:, k],
            excitation["line_current"][:, k],
            s.alf3_feed.rate(s.alf3_feed.setpoint - x[:, 2] / bath) + excitation["alf3_impulses"][:, k],
            s.metal_tapping.rate(x[:, 4] - s.metal_tapping.setpoint),
            excitation["anode_cathode_distance"][:, k],
        ],
        axis=-1,
    )


def simulate(
    model: CellModel, x0: np.ndarray, operator: Operator, settings: SimulationSettings, compiled: bool = False
) -> Trajectories:
    """Simulate n trajectories together from x0 (n, 8), their inputs set by ``operator``; ``compiled``:
    each step by the compiled model (:class:`.compiled.CompiledModel`, numpy's numbers, without
    numpy's cost per call: a few cells over days of steps)."""
    n, steps = x0.shape[0], settings.steps
    x = np.empty((n, steps, 8))
    u = np.empty((n, steps, 5))
    x[:, 0] = x0
    if compiled:
        step = CompiledModel(model, settings.dt, derivatives=False).step
    else:
        step = partial(rk4_step, model.rhs, dt=settings.dt)
    with np.errstate(all="ignore"):
        u[:, 0] = operator.inputs(x0, 0)
        for k in range(1, steps):
            x[:, k] = step(x[:, k - 1], u[:, k - 1])
            taken = operator.bath_heat_taken()
            if np.any(taken):  # the heat leaves the bath after the model's step (operator splitting)
                x[:, k, 5] -= taken * settings.dt * model.state_rate_per_flow(x[:, k - 1], u[:, k - 1])[:, 5]
            u[:, k] = operator.inputs(x[:, k], k)
    return Trajectories(x, u)


def simulate_set(
    model: CellModel,
    settings: SimulationSettings,
    n_trajectories: int,
    seed: int,
    replicate: int,
    stream_name: str,
    max_attempts: int = 10,
    compiled: bool = False,
) -> tuple[Trajectories, np.ndarray]:
    """A data set of ``n_trajectories``, with its per-trajectory attempt counts.

    Trajectory i draws its initial state from stream (``stream_name``, i) and its
    excitation from (``stream_name``, i, attempt).  A trajectory whose simulation
    leaves the finite numbers is simulated again from the same initial state with
    the next attempt's excitation, as the authors' code does; the number of
    attempts is returned so that it can be recorded.  Under ``settings.operation``
    "pot_line" the excitation is the pot line's (:mod:`costa.pot_line`): each cell's
    phase and current noise from (``stream_name``/pot_line, i, attempt).  ``compiled``: see :func:`simulate`.
    """
    initial = settings.initial
    if settings.operation == "pot_line" and settings.pot_line is not None:
        initial = replace(initial, c2_percent=settings.pot_line.c2_percent)
    x0 = np.stack(
        [draw_initial_state(seeds.numpy_generator(seed, replicate, stream_name, i), initial)
         for i in range(n_trajectories)]
    )  # fmt: skip
    attempts = np.zeros(n_trajectories, dtype=np.int64)
    x = np.empty((n_trajectories, settings.steps, 8))
    u = np.empty((n_trajectories, settings.steps, 5))
    todo = np.arange(n_trajectories)
    while todo.size:
        if attempts[todo].max() >= max_attempts:
            raise RuntimeError(
                f"{stream_name}: trajectories {todo.tolist()} left the finite numbers in {max_attempts} attempts"
            )
        operator = _operator(model, settings, seed, replicate, stream_name, todo, attempts[todo])
        result = simulate(model, x0[todo], operator, settings, compiled)
        x[todo], u[todo] = result.x, result.u
        finite = np.isfinite(result.x).all(axis=(1, 2)) & np.isfinite(result.u).all(axis=(1, 2))
        attempts[todo] += 1
        todo = todo[~finite]
    return Trajectories(x, u), attempts


def _operator(model, settings, seed, replicate, stream_name, indices, attempts) -> Operator:
    if settings.operation == "excitation":
        return Excited(_stacked_excitation(settings, seed, replicate, stream_name, indices, attempts), settings)
    if settings.operation != "pot_line" or settings.pot_line is None:
        raise ValueError(
            f"unknown operation {settings.operation!r} (or simulation.pot_line missing); known: excitation, pot_line"
        )
    rngs = [
        seeds.numpy_generator(seed, replicate, f"{stream_name}/pot_line", i, a)
        for i, a in zip(indices, attempts, strict=True)
    ]
    phase = np.array([rng.uniform(0, DAY_S) for rng in rngs])
    noise = np.stack([rng.standard_normal(settings.steps) for rng in rngs])
    return PotLineOperation(settings.pot_line, model, settings.dt, noise, phase)


def _stacked_excitation(settings, seed, replicate, stream_name, indices, attempts) -> dict[str, np.ndarray]:
    per_trajectory = [
        draw_excitation(seeds.numpy_generator(seed, replicate, f"{stream_name}/excitation", i, a), settings)
        for i, a in zip(indices, attempts, strict=True)
    ]
    return {key: np.stack([d[key] for d in per_trajectory]) for key in per_trajectory[0]}
