"""A pot line's operation: what a smelter's controllers do to a cell, as the inputs u1..u5 of each 10-s step.

Unlike the paper's excitation (the line current stepped by tens of kA, random feeds), a pot line
holds its current and acts on a few measurements (``simulation.pot_line`` in the config):

- **line current** (u2): the line's set point with small noise (0.3 % std a step, the rectifiers' ripple);
- **alumina** (u1): point-feeder doses of ``dose_kg`` at a rate that alternates between underfeeding
  (``underfeed`` x nominal) until the cell voltage has risen ``track_rise_v`` above its lowest value
  of that period (the bath running short of alumina; at most ``underfeed_max_s``), and overfeeding
  (``overfeed`` x nominal) for ``overfeed_s``; the nominal rate is the consumption at the set current;
- **anode beam** (u5): while overfeeding, at most every ``beam_every_s``, one step of ``beam_step_m`` down
  or up where the voltage lies more than ``voltage_band_v`` from ``voltage_target_v``;
- **AlF3** (u3): a dose halfway through each shift, ``alf3_base_kg`` plus ``alf3_gain_kg`` per unit of
  AlF3 fraction that the last daily bath sample lies below ``alf3_setpoint`` (0 .. ``alf3_max_kg``), in one
  step;
- **tapping** (u4): one tap a day, half a day after the bath sample: the metal above
  ``metal_setpoint_kg`` at its start, siphoned over ``tap_s``;
- **anode changes**, where ``anode_change_s`` > 0: every ``anode_change_s`` from the record's start, one
  new anode of ``anode_kg`` carbon set cold into the bath.  It takes ``anode_heat_j_per_kg`` from the
  bath as it heats, at a rate that decays with ``anode_heat_tau_s`` (:meth:`PotLineOperation.bath_heat_taken`):
  a disturbance the model does not describe (it has no input for it), as on a real line.

Doses and taps are amounts: one step carries amount / dt [kg/s], as the events table turns them into
rates (:mod:`costa.events`).  Each cell's shift, sample and tap times start at a random phase, and
its current noise is its own stream: the operation is as reproducible as the paper's excitation.
The controllers read the true bath at their sample times and the true voltage at the set current (a
pot's controller tracks the pseudo-resistance, which the current's ripple does not move): a plant's
readings are noisier, which changes when they act, not what the model must explain.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from .compiled import CompiledModel
from .physics import CellModel

__all__ = ["PotLine", "PotLineOperation"]

DAY_S = 86400.0
SHIFT_S = 28800.0


@dataclass(frozen=True)
class PotLine:
    """The settings of a pot line's controllers (see the module docstring; units in the names)."""

    current_a: float
    current_noise: float
    alumina_kg_per_as: float
    dose_kg: float
    underfeed: float
    overfeed: float
    overfeed_s: float
    underfeed_max_s: float
    track_rise_v: float
    voltage_target_v: float
    voltage_band_v: float
    beam_step_m: float
    beam_every_s: float
    acd_m: float
    alf3_setpoint: float
    alf3_base_kg: float
    alf3_gain_kg: float
    alf3_max_kg: float
    metal_setpoint_kg: float
    tap_s: float
    anode_change_s: float  # 0: none
    anode_kg: float
    anode_heat_j_per_kg: float
    anode_heat_tau_s: float
    #: the range of a cell's first alumina fraction [%]: an operated cell is not started in the
    #: starved bath (below 2.3 %) where the model's voltage swings by volts
    c2_percent: tuple[int, int]

    @classmethod
    def from_config(cls, section: Mapping) -> PotLine:
        """From ``simulation.pot_line`` of the validated config."""
        values = {name: float(value) for name, value in section.items() if name != "c2_percent"}
        return cls(**values, c2_percent=tuple(section["c2_percent"]))

    @property
    def nominal_feed(self) -> float:
        """Alumina consumption at the set current [kg/s]: the feeders' nominal rate."""
        return self.alumina_kg_per_as * self.current_a


class PotLineOperation:
    """The controllers of n cells, stepped together: :meth:`inputs` gives u_k (n, 5) from the states x_k (n, 8).

    ``noise`` (n, steps): each cell's standard normal draws of the current's ripple; ``phase`` (n,):
    each cell's offset [s] of its shifts, samples and taps (0 .. one day).
    """

    def __init__(self, line: PotLine, model: CellModel, dt: float, noise: np.ndarray, phase: np.ndarray):
        n = len(phase)
        self.line, self.model, self.dt = line, model, dt
        self.voltmeter = CompiledModel(model, dt, ("U_cell",), derivatives=False)
        self.current = line.current_a * (1 + line.current_noise * noise)
        self.phase = phase
        self.acd = np.full(n, line.acd_m)
        self.overfeeding = np.ones(n, dtype=bool)  # a cell starts with an overfeed: its alumina is unknown
        self.since = np.zeros(n)  # seconds in the current feeding period
        self.lowest = np.full(n, np.inf)  # the lowest voltage of the underfeeding period [V]
        self.credit = np.zeros(n)  # alumina owed by the feeders [kg]
        self.last_beam = np.full(n, -np.inf)
        self.alf3_sample = np.full(n, line.alf3_setpoint)
        self.tap = np.zeros(n)  # tapping rate of the running tap [kg/s]
        self.anode_heat = np.zeros(n)  # heat the new anodes take from the bath this step [W]

    def inputs(self, x: np.ndarray, k: int) -> np.ndarray:
        """u_k (n, 5) for the states x_k (n, 8); advances the controllers by one step."""
        line, dt, t = self.line, self.dt, k * self.dt
        clock = t + self.phase
        u = np.zeros((len(x), 5))
        u[:, 1], u[:, 4] = line.current_a, self.acd
        voltage = self.voltmeter.sense(x, u)[:, 0]
        u[:, 1] = self.current[:, k]
        self._track(voltage, clock)
        self.credit += line.nominal_feed * np.where(self.overfeeding, line.overfeed, line.underfeed) * dt
        dose = self.credit >= line.dose_kg
        self.credit -= np.where(dose, line.dose_kg, 0.0)
        u[:, 0] = np.where(dose, line.dose_kg / dt, 0.0)
        bath = x[:, 1:4].sum(axis=1)
        sampled = _ticks(clock, DAY_S, dt)
        self.alf3_sample = np.where(sampled, x[:, 2] / bath, self.alf3_sample)
        shift = _ticks(clock + SHIFT_S / 2, SHIFT_S, dt)
        alf3 = np.clip(
            line.alf3_base_kg + line.alf3_gain_kg * (line.alf3_setpoint - self.alf3_sample), 0, line.alf3_max_kg
        )
        u[:, 2] = np.where(shift, alf3 / dt, 0.0)
        tap_starts = _ticks(clock + DAY_S / 2, DAY_S, dt)
        self.tap = np.where(tap_starts, np.maximum(x[:, 4] - line.metal_setpoint_kg, 0.0) / line.tap_s, self.tap)
        self.tap = np.where((clock + DAY_S / 2) % DAY_S >= line.tap_s, 0.0, self.tap)
        u[:, 3] = self.tap
        self._change_anodes(t)
        return u

    def bath_heat_taken(self) -> np.ndarray:
        """The heat [W] (n,) the anodes set since the start take from each bath during the step just set."""
        return self.anode_heat

    def _change_anodes(self, t: float) -> None:
        """Decay the new anodes' heat uptake over one step; set a new anode where one is due (t > 0)."""
        line = self.line
        if line.anode_change_s <= 0:
            return
        self.anode_heat *= np.exp(-self.dt / line.anode_heat_tau_s)
        if t > 0 and t % line.anode_change_s < self.dt:  # the steps' uptake sums to the anode's heat
            self.anode_heat -= (
                line.anode_kg * line.anode_heat_j_per_kg * np.expm1(-self.dt / line.anode_heat_tau_s) / self.dt
            )

    def _track(self, voltage: np.ndarray, clock: np.ndarray) -> None:
        """Switch between under- and overfeeding, and move the beam while overfeeding."""
        line = self.line
        self.since += self.dt
        self.lowest = np.where(self.overfeeding, np.inf, np.minimum(self.lowest, voltage))
        starved = ~self.overfeeding & (
            (voltage - self.lowest >= line.track_rise_v) | (self.since >= line.underfeed_max_s)
        )
        done = self.overfeeding & (self.since >= line.overfeed_s)
        self.overfeeding = (self.overfeeding | starved) & ~done
        self.since = np.where(starved | done, 0.0, self.since)
        move = self.overfeeding & (clock - self.last_beam >= line.beam_every_s)
        error = voltage - line.voltage_target_v
        step = np.where(error > line.voltage_band_v, -1.0, np.where(error < -line.voltage_band_v, 1.0, 0.0))
        self.acd = np.where(move, self.acd + step * line.beam_step_m, self.acd)
        self.last_beam = np.where(move & (step != 0), clock, self.last_beam)


def _ticks(clock: np.ndarray, period: float, dt: float) -> np.ndarray:
    """Whether a periodic event (every ``period`` [s], at clock 0, period, ...) falls in this step."""
    return clock % period < dt
