"""What a cell's instruments measure: channels, sampling intervals and noise.

A *channel* is one measured quantity: a state ``x1..x8``, the cell voltage
``U_cell`` [V] (the model's U = g5 + u2 u5 / (2620 g2)), the pot voltage ``U_pot``
[V] (U + E0 + R_ext u2, :mod:`costa.observe`), or the bath's Al2O3 and AlF3 mass
fractions ``c2``, ``c3`` [-], or the metal a tap removed as the crane scale weighs it,
``m_tap`` [kg/s].  A :class:`SensorSet` says which channels are measured, every how
many seconds (or at each tap, :data:`AT_TAPS`), and with what Gaussian noise (absolute,
in the channel's unit).  :func:`measure` turns a simulated truth into the tidy table a
plant would log: inputs at every step (they are logged commands), each measured
channel at its own samples and NaN in between, unmeasured channels absent; a sample outside
the channel's plausible range (:data:`costa.variables.PLAUSIBLE_RANGE`: a pot voltage outside
2.5-7 V) is left empty, as a plant's log leaves it.

A set may *vary* (:class:`RecordVariation`): each drawn case of the discovery benchmark then
draws its record from its seed (how its cells are run, how long, how often the hand-sampled
channels are sampled), so that one set spans a pot line's regimes (:meth:`SensorSet.drawn`).

A channel sampled less often than every step starts at a random phase per
trajectory (drawn from the given stream): hand samples are not taken at the same
minute in every cell.  A channel sampled at taps is read once a tap, at its first
step (a tap is a run of steps with logged u4 > 0): the scale's weight of the tap
divided by its duration is the delivered tapping rate there, exactly where the share
delivered does not change during the tap.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from .data import to_table
from .observe import observe
from .physics import CellModel
from .variables import CHANNELS, INPUTS, PLAUSIBLE_RANGE, STATES

__all__ = [
    "AT_TAPS",
    "AVAILABLE",
    "CHANNELS",
    "LOGGED_S",
    "RecordVariation",
    "declared_noise",
    "Sensor",
    "SensorSet",
    "measure",
    "sensor_sets_from_config",
    "tap_starts",
]


#: ``every_s`` of a channel read once at each tap (the crane scale's weight of the metal tapped).
AT_TAPS = "tap"
#: a channel sampled at least this often [s] is logged; a rarer one is hand-sampled (a varied record
#: draws the hand-sampled channels' interval)
LOGGED_S = 60.0


@dataclass(frozen=True)
class Sensor:
    """One channel sampled every ``every_s`` seconds (or at each tap: :data:`AT_TAPS`) with Gaussian
    noise of std ``noise``.

    ``noise`` None: the noise of the data set it is applied to (a shipped case's
    fraction of each state's std), for the ``full`` set that reproduces today's data.
    """

    channel: str
    every_s: float | str
    noise: float | None = None

    def __post_init__(self):
        if self.channel not in CHANNELS:
            raise ValueError(f"unknown channel {self.channel!r}; known: {list(CHANNELS)}")
        if isinstance(self.every_s, str) and self.every_s != AT_TAPS:
            raise ValueError(
                f"sensor {self.channel!r}: every_s is a number of seconds or {AT_TAPS!r}, not {self.every_s!r}"
            )

    @property
    def interval(self) -> str:
        """``every 600 s`` or ``at each tap``."""
        return "at each tap" if self.every_s == AT_TAPS else f"every {self.every_s:g} s"


#: What a pot line can measure, at its usual intervals and with typical noise (the ones
#: "what to measure next" ranks): the voltage log (5 mV once the bubble noise is filtered);
#: a thermocouple dip of the bath, hourly or daily (1.5 degC); a bath sample's AlF3 by XRF
#: (0.002) and Al2O3 by oxygen analysis (0.001), per shift or daily; a metal-height dip,
#: per shift or daily (15 kg of metal); a shell thermocouple every 10 min (2 degC).  The
#: ledge and the individual masses have no routine measurement.
AVAILABLE: tuple[Sensor, ...] = (
    Sensor("U_cell", 10, 0.005),
    Sensor("x6", 3600, 1.5),
    Sensor("x6", 86400, 1.5),
    Sensor("c3", 28800, 0.002),
    Sensor("c3", 86400, 0.002),
    Sensor("c2", 28800, 0.001),
    Sensor("c2", 86400, 0.001),
    Sensor("x5", 28800, 15.0),
    Sensor("x5", 86400, 15.0),
    Sensor("x8", 600, 2.0),
)


@dataclass(frozen=True)
class RecordVariation:
    """How a varied set's record is drawn: the cells run one of ``operations``; trajectories of a whole
    number of hours, log-uniform in ``hours`` (low, high); the hand-sampled channels (those declared
    rarer than :data:`LOGGED_S`) all every one of ``every_s`` seconds (the logged ones as declared)."""

    operations: tuple[str, ...]
    hours: tuple[float, float]
    every_s: tuple[float, ...]


@dataclass(frozen=True)
class SensorSet:
    """The channels a cell's instruments measure; ``hours``: the length of its trajectories, ``trajectories``
    and ``held_out_trajectories``: how many (None: the defaults); ``operation``: how the measured cells
    are run (:attr:`costa.simulate.SimulationSettings.operation`); ``vary``: how a drawn case's record
    varies (None: as declared)."""

    name: str
    sensors: tuple[Sensor, ...]
    hours: float | None = None
    trajectories: int | None = None
    held_out_trajectories: int | None = None
    operation: str = "excitation"
    vary: RecordVariation | None = None

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(s.channel for s in self.sensors)

    def steps(self, dt: float, default: int) -> int:
        """Samples per trajectory at a step of ``dt`` [s]."""
        return default if self.hours is None else int(round(self.hours * 3600 / dt))

    def drawn(self, rng: np.random.Generator) -> SensorSet:
        """The record of one case of a varied set (:class:`RecordVariation`), drawn from ``rng``; itself
        where the set does not vary."""
        if self.vary is None:
            return self
        v = self.vary
        operation = v.operations[rng.integers(len(v.operations))]
        hours = float(np.round(np.exp(rng.uniform(*np.log(v.hours)))))
        every = v.every_s[rng.integers(len(v.every_s))]
        sensors = tuple(
            Sensor(s.channel, every, s.noise) if s.every_s != AT_TAPS and s.every_s > LOGGED_S else s
            for s in self.sensors
        )
        return replace(self, sensors=sensors, hours=hours, operation=operation, vary=None)

    def describe(self) -> str:
        """How its cells are run and what they measure, in words."""
        how = "run as a pot line runs them" if self.operation == "pot_line" else "run by the paper's controllers"
        return f"{how}, " + ", ".join(f"{s.channel} {s.interval}" for s in self.sensors)


def measure(
    model: CellModel,
    x: np.ndarray,
    u: np.ndarray,
    dt: float,
    sensors: SensorSet,
    rng: np.random.Generator,
    default_noise: Mapping[str, float] | None = None,
) -> pd.DataFrame:
    """The table a plant would log of true states x (n, K, 8) and inputs u (n, K, 5).

    ``model`` is the true model (it gives the true cell voltage); ``default_noise``
    the noise std of channels whose sensor leaves it to the data set.
    """
    n, steps = x.shape[:2]
    timed = [s for s in sensors.sensors if s.every_s != AT_TAPS]
    at_taps = [s for s in sensors.sensors if s.every_s == AT_TAPS]
    table = to_table(x, u, dt).drop(columns=list(STATES))
    # the timed channels' noise first, as one array (the full set is today's data), their phases next,
    # the taps' readings last: adding a tap channel to a set leaves its other samples as they were
    noisy = _noisy(model, x, u, timed, sensors.name, default_noise, rng)
    for c, sensor in enumerate(timed):
        table[sensor.channel] = np.where(_every(sensor.every_s, dt, n, steps, rng), noisy[..., c], np.nan).ravel()
    if at_taps:
        noisy = _noisy(model, x, u, at_taps, sensors.name, default_noise, rng)
        for c, sensor in enumerate(at_taps):
            table[sensor.channel] = np.where(tap_starts(u), noisy[..., c], np.nan).ravel()
    return table[[*table.columns[: -len(sensors.sensors)], *sensors.channels]]


def _noisy(
    model: CellModel,
    x: np.ndarray,
    u: np.ndarray,
    sensors: list[Sensor],
    set_name: str,
    default_noise: Mapping[str, float] | None,
    rng: np.random.Generator,
) -> np.ndarray:
    """(n, K, C) the sensors' channels with their Gaussian noise, drawn as one array; NaN outside a
    channel's plausible range."""
    values = observe(model, x, u, [s.channel for s in sensors])
    noise = np.array([_noise(sensor, set_name, default_noise) for sensor in sensors])
    noisy = values + rng.normal(size=values.shape) * noise
    for c, sensor in enumerate(sensors):
        low, high = PLAUSIBLE_RANGE.get(sensor.channel, (-np.inf, np.inf))
        noisy[..., c] = np.where((noisy[..., c] < low) | (noisy[..., c] > high), np.nan, noisy[..., c])
    return noisy


def tap_starts(u: np.ndarray) -> np.ndarray:
    """(n, K) True at the first step of each tap: logged u4 > 0 where the step before had none."""
    tapping = u[..., INPUTS.index("u4")] > 0
    return tapping & ~np.pad(tapping, [(0, 0)] * (tapping.ndim - 1) + [(1, 0)])[..., :-1]


def _every(every_s: float, dt: float, n: int, steps: int, rng: np.random.Generator) -> np.ndarray:
    """(n, K) True every ``every_s`` seconds, from a random phase per trajectory."""
    every = max(1, int(round(every_s / dt)))
    phase = rng.integers(0, every, size=n) if every > 1 else np.zeros(n, dtype=int)
    return (np.arange(steps)[None, :] - phase[:, None]) % every == 0


def _noise(sensor: Sensor, set_name: str, default: Mapping[str, float] | None) -> float:
    noise = sensor.noise if sensor.noise is not None else (default or {}).get(sensor.channel)
    if noise is None:
        raise ValueError(f"sensor {sensor.channel!r} of set {set_name!r} gives no noise and the data set gives none")
    return float(noise)


def declared_noise(sets: Mapping[str, Mapping], name: str) -> dict[str, float]:
    """The noise std of each channel of ``discovery.sensor_sets[name]`` that states one, in the channel's unit."""
    return {channel: spec["noise"] for channel, spec in sets[name]["channels"].items() if "noise" in spec}


def sensor_sets_from_config(sets: Mapping[str, Mapping]) -> dict[str, SensorSet]:
    """``discovery.sensor_sets`` of the config: name -> {operation, hours, trajectories, held_out_trajectories,
    vary, channels: {channel: {every_s, noise}}}."""
    return {
        name: SensorSet(
            name=name,
            sensors=tuple(Sensor(channel, s["every_s"], s.get("noise")) for channel, s in spec["channels"].items()),
            hours=spec.get("hours"),
            trajectories=spec.get("trajectories"),
            held_out_trajectories=spec.get("held_out_trajectories"),
            operation=spec.get("operation", "excitation"),
            vary=_variation(spec["vary"]) if spec.get("vary") else None,
        )
        for name, spec in sets.items()
    }


def _variation(spec: Mapping) -> RecordVariation:
    """``vary`` of a sensor set: {operation: [...], hours: [low, high], every_s: [...]}."""
    return RecordVariation(
        operations=tuple(spec["operation"]), hours=(float(spec["hours"][0]), float(spec["hours"][1])),
        every_s=tuple(float(e) for e in spec["every_s"]),
    )  # fmt: skip
