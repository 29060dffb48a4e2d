"""The pots of a line and their records: simulated (each pot one cell with its own start, inputs and
noise, some sharing a shipped case's hidden effect) or your files in the data contract."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import pandas as pd

from .. import seeds
from ..data import load_trajectories
from ..discover.cases.shipped import CASES
from ..discover.cases.tables import case_noise, record_settings
from ..physics import model_from_config
from ..sensors import measure
from ..simulate import simulate_set

__all__ = ["Line", "pot_record"]

#: the effect of a simulated pot outside every group
NO_EFFECT = "no_effect"


@dataclass(frozen=True, kw_only=True)
class Line:
    """A pot line (``line:`` of the config): its ``pots`` by name; for a simulated line the sensor set
    each pot is measured by and the shipped case whose effect each pot has (``effects``); for yours
    each pot's record file (``records``) and the noise of its sparse channels (``noise``)."""

    name: str
    pots: tuple[str, ...]
    starting_model: str
    held_out_fraction: float
    sensors: str | None = None
    effects: Mapping[str, str] = field(default_factory=dict)
    records: Mapping[str, str] = field(default_factory=dict)
    noise: Mapping[str, float] = field(default_factory=dict)

    @classmethod
    def from_config(cls, section: Mapping) -> Line:
        """From the validated ``line:`` section: ``simulated: {pots, sensors, groups: [{case, pots}]}`` (pots by
        index, named pot00, pot01, ...) or ``records: {pot: path}`` with ``noise``."""
        common = {
            "name": section["name"], "starting_model": section["starting_model"],
            "held_out_fraction": section["held_out_fraction"],
        }  # fmt: skip
        simulated = section.get("simulated")
        if simulated:
            pots = tuple(f"pot{i:02d}" for i in range(simulated["pots"]))
            effects = dict.fromkeys(pots, NO_EFFECT)
            for group in simulated["groups"]:
                effects.update({pots[i]: group["case"] for i in group["pots"]})
            return cls(**common, pots=pots, sensors=simulated["sensors"], effects=effects)
        records = dict(section["records"])
        return cls(**common, pots=tuple(records), records=records, noise=dict(section.get("noise") or {}))

    @property
    def simulated(self) -> bool:
        return not self.records

    def declared_noise(self, config: Mapping) -> dict[str, float]:
        """The noise std of the channels too sparse to estimate it: the sensor set's, or yours."""
        if not self.simulated:
            return dict(self.noise)
        spec = config["discovery"]["sensor_sets"][self.sensors]["channels"]
        return {channel: float(s["noise"]) for channel, s in spec.items() if "noise" in s}


def pot_record(config: Mapping, line: Line, pot: str) -> pd.DataFrame:
    """One pot's record, one trajectory in the data contract: yours as read, or simulated: one cell run
    and measured as the line's sensor set says, with its effect's true model, from the pot's own streams."""
    if not line.simulated:
        return load_trajectories(line.records[pot])
    sensor_set, settings = record_settings(config, line.sensors)
    case = CASES[line.effects[pot]]
    true, _ = case.models(model_from_config(config["physics"])[0])
    stream = f"line/{line.name}/{pot}"
    trajectories, _ = simulate_set(
        true, settings, n_trajectories=1, seed=config["seed"], replicate=0, stream_name=stream, compiled=True
    )
    x, u = trajectories.x, trajectories.u
    default = case_noise(true, x, u, sensor_set, case.noise)
    rng = seeds.numpy_generator(config["seed"], 0, f"{stream}/sensors")
    return measure(true, x, u=u, dt=settings.dt, sensors=sensor_set, rng=rng, default_noise=default)
