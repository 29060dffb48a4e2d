"""The pots of a line and their records: simulated (each pot one cell with its own start, inputs and
noise, some sharing a shipped case's hidden effect), your files in the data contract, or your pots'
historian exports, each imported as the one-pot import does (:mod:`costa.historian`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from .. import seeds
from ..data import TrajectoryDataError, load_trajectories
from ..discover.cases.shipped import CASES
from ..discover.cases.tables import case_noise, record_settings
from ..physics import model_from_config
from ..sensors import measure
from ..simulate import simulate_set

__all__ = ["Line", "imported_pot", "pot_record"]

#: the effect of a simulated pot outside every group
NO_EFFECT = "no_effect"


@dataclass(frozen=True, kw_only=True)
class Line:
    """A pot line (``line:`` of the config): its ``pots`` by name; for a simulated line the sensor set
    each pot is measured by and the shipped case whose effect each pot has (``effects``); for yours
    each pot's record file (``records``) or its historian files and import settings (``historian``), and
    the noise of its sparse channels (``noise``)."""

    name: str
    pots: tuple[str, ...]
    starting_model: str
    held_out_fraction: float
    sensors: str | None = None
    effects: Mapping[str, str] = field(default_factory=dict)
    records: Mapping[str, str] = field(default_factory=dict)
    historian: Mapping = field(default_factory=dict)
    noise: Mapping[str, float] = field(default_factory=dict)

    @classmethod
    def from_config(cls, section: Mapping) -> Line:
        """From the validated ``line:`` section: ``simulated: {pots, sensors, groups: [{case, pots}]}`` (pots by
        index, named pot00, pot01, ...), ``records: {pot: path}`` or ``historian: {pots: {pot: files}, ...}``, with ``noise``."""
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
        noise = dict(section.get("noise") or {})
        if section.get("historian"):
            historian = dict(section["historian"])
            return cls(**common, pots=tuple(historian["pots"]), historian=historian, noise=noise)
        records = dict(section["records"])
        return cls(**common, pots=tuple(records), records=records, noise=noise)

    @property
    def simulated(self) -> bool:
        return not self.records and not self.historian

    def historian_files(self, pot: str) -> dict[str, str]:
        """One of your pots' historian files: its export, tag map (its own or the line's), events and lab samples where given."""
        return {"tags": self.historian["tags"], **self.historian["pots"][pot]}

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


def imported_pot(line: Line, pot: str, dt_s: float, folder: str | Path) -> tuple[pd.DataFrame, str]:
    """One of your pots from its historian export, on the model's step ``dt_s`` [s], and what was kept:
    the import's record, events, report and figure written to ``folder`` (as the one-pot import
    writes them), its events added to its inputs.  A pot is one trajectory of a line: where the
    import cut the record (an input missing longer than ``max_gap_s``), its longest stretch."""
    from ..config import historian_settings
    from ..events import load_trajectories_with_events
    from ..historian import import_historian, read_tag_map
    from ..historian.report import write_import

    files, folder = line.historian_files(pot), Path(folder)
    # a pot is one stretch: not cut into trajectories, nor at its anode changes
    settings = historian_settings({**line.historian, "trajectory_hours": None, "anode_change_after_s": 0.0}, dt_s)
    try:
        imported = import_historian(
            files["export"], read_tag_map(files["tags"]), settings, files.get("events"), files.get("lab")
        )
    except TrajectoryDataError as error:
        raise TrajectoryDataError(f"line.historian.pots.{pot}: {error}") from None
    write_import(imported, folder, {"line": line.name, "pot": pot, "historian": files})
    record = load_trajectories_with_events(
        folder / "record.parquet", folder / "events.csv", line.historian["unlogged_inputs"]
    )
    steps = record.groupby("trajectory", sort=False).size()
    longest = steps.idxmax()
    kept = f"all {steps.iloc[0] * dt_s / 3600:.1f} h" if len(steps) == 1 else (
        f"its longest stretch of {len(steps)}, {steps[longest] * dt_s / 3600:.1f} h of {steps.sum() * dt_s / 3600:.1f} h "
        f"(an input missing longer than max_gap_s = {line.historian['max_gap_s']:g} s cuts it: {folder / 'import.md'})"
    )  # fmt: skip
    return record[record["trajectory"] == longest].assign(trajectory=0).reset_index(drop=True), kept
