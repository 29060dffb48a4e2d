"""What a cell's instruments measure: channels, sampling intervals and noise.

A *channel* is one measured quantity: a state ``x1..x8``, the cell voltage
``U_cell`` [V] (the model's U = g5 + u2 u5 / (2620 g2)), the pot voltage ``U_pot``
[V] (U + E0 + R_ext u2, :mod:`costa.observe`), or the bath's Al2O3 and AlF3 mass
fractions ``c2``, ``c3`` [-].  A :class:`SensorSet` says which channels are
measured, every how many seconds, and with what Gaussian noise (absolute, in the
channel's unit).  :func:`measure` turns a simulated truth into the tidy table a
plant would log: inputs at every step (they are logged commands), each measured
channel at its own samples and NaN in between, unmeasured channels absent.

A channel sampled less often than every step starts at a random phase per
trajectory (drawn from the given stream): hand samples are not taken at the same
minute in every cell.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .data import to_table
from .observe import observe
from .physics import CellModel
from .variables import CHANNELS, STATES

__all__ = ["AVAILABLE", "CHANNELS", "Sensor", "SensorSet", "measure", "sensor_sets_from_config"]


@dataclass(frozen=True)
class Sensor:
    """One channel sampled every ``every_s`` seconds with Gaussian noise of std ``noise``.

    ``noise`` None: the noise of the data set it is applied to (a shipped case's
    fraction of each state's std), for the ``full`` set that reproduces today's data.
    """

    channel: str
    every_s: float
    noise: float | None = None

    def __post_init__(self):
        if self.channel not in CHANNELS:
            raise ValueError(f"unknown channel {self.channel!r}; known: {list(CHANNELS)}")


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
class SensorSet:
    """The channels a cell's instruments measure; ``hours``: the length of its trajectories, ``trajectories``
    and ``held_out_trajectories``: how many (None: the defaults); ``operation``: how the measured cells
    are run (:attr:`costa.simulate.SimulationSettings.operation`)."""

    name: str
    sensors: tuple[Sensor, ...]
    hours: float | None = None
    trajectories: int | None = None
    held_out_trajectories: int | None = None
    operation: str = "excitation"

    @property
    def channels(self) -> tuple[str, ...]:
        return tuple(s.channel for s in self.sensors)

    def steps(self, dt: float, default: int) -> int:
        """Samples per trajectory at a step of ``dt`` [s]."""
        return default if self.hours is None else int(round(self.hours * 3600 / dt))


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
    values = observe(model, x, u, sensors.channels)
    noise = np.array([_noise(sensor, sensors.name, default_noise) for sensor in sensors.sensors])
    noisy = values + rng.normal(size=values.shape) * noise  # drawn first, as one array: the full set is today's data
    table = to_table(x, u, dt).drop(columns=list(STATES))
    for c, sensor in enumerate(sensors.sensors):
        every = max(1, int(round(sensor.every_s / dt)))
        phase = rng.integers(0, every, size=n) if every > 1 else np.zeros(n, dtype=int)
        sampled = (np.arange(steps)[None, :] - phase[:, None]) % every == 0
        table[sensor.channel] = np.where(sampled, noisy[..., c], np.nan).ravel()
    return table


def _noise(sensor: Sensor, set_name: str, default: Mapping[str, float] | None) -> float:
    noise = sensor.noise if sensor.noise is not None else (default or {}).get(sensor.channel)
    if noise is None:
        raise ValueError(f"sensor {sensor.channel!r} of set {set_name!r} gives no noise and the data set gives none")
    return float(noise)


def sensor_sets_from_config(sets: Mapping[str, Mapping]) -> dict[str, SensorSet]:
    """``discovery.sensor_sets`` of the config: name -> {operation, hours, trajectories, held_out_trajectories,
    channels: {channel: {every_s, noise}}}."""
    return {
        name: SensorSet(
            name,
            tuple(Sensor(channel, s["every_s"], s.get("noise")) for channel, s in spec["channels"].items()),
            spec.get("hours"),
            spec.get("trajectories"),
            spec.get("held_out_trajectories"),
            spec.get("operation", "excitation"),
        )
        for name, spec in sets.items()
    }
