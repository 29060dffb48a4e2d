"""A case's measured-like data: training and held-out tables simulated with its true model."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np
import pandas as pd

from ... import seeds
from ...observe import observe
from ...physics import model_from_config
from ...sensors import Sensor, SensorSet, measure, sensor_sets_from_config
from ...simulate import SimulationSettings, simulate_set
from .drawn import DRAWN_NAME
from .shipped import HiddenEffectCase
from .unshipped import find_case

__all__ = [
    "case_noise", "case_table", "case_tables", "record_settings", "simulated_cells", "simulated_data", "with_channel",
]  # fmt: skip


def case_tables(
    config: Mapping, case: str | HiddenEffectCase, sensors: str = "full"
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Training and held-out tables of a case (a shipped or unshipped one by name), simulated with its true model
    and measured by the sensor set ``sensors`` of ``discovery.sensor_sets``.

    The cells are run as the sensor set's ``operation`` says (the paper's excitation, or a pot line's
    controllers), or, for a drawn case under a set that varies, as its record is drawn
    (:func:`record_settings`).  A sensor that leaves its noise open gets the case's level: that fraction of
    its channel's std over the data set (the full set is then every state with the case's noise).
    """
    case = find_case(case) if isinstance(case, str) else case
    return case_table(config, case, sensors, "train"), case_table(config, case, sensors, "held_out")


def case_table(config: Mapping, case: HiddenEffectCase, sensors: str, split: str) -> pd.DataFrame:
    """One ``split`` ("train" or "held_out") of :func:`case_tables`."""
    sensor_set, settings = record_settings(config, sensors, case.name)
    true, _ = case.models(model_from_config(config["physics"])[0])
    x, u = simulated_cells(config, case, sensors, split)
    default = case_noise(true, x, u, sensor_set, case.noise)
    stream = f"discovery/{case.name}/{split}"
    noise = f"{stream}/noise" if sensors == "full" else f"{stream}/sensors/{sensors}"
    rng = seeds.numpy_generator(config["seed"], 0, noise)
    return measure(true, x, u=u, dt=settings.dt, sensors=sensor_set, rng=rng, default_noise=default)


def with_channel(
    config: Mapping, case: str | HiddenEffectCase, sensors: str, split: str, table: pd.DataFrame, sensor: Sensor
) -> pd.DataFrame:
    """``table`` (the ``split`` of :func:`case_tables` under ``sensors``) with ``sensor`` added: the record's own
    samples as they were, the added channel's (or, where the record samples it more rarely, its samples between
    the record's) with noise and phases from a stream of its own."""
    case = find_case(case) if isinstance(case, str) else case
    _, settings = record_settings(config, sensors, case.name)
    true, _ = case.models(model_from_config(config["physics"])[0])
    x, u = simulated_cells(config, case, sensors, split)
    stream = f"discovery/{case.name}/{split}/sensors/{sensors}/added/{sensor.channel}"
    rng = seeds.numpy_generator(config["seed"], 0, stream)
    added = measure(true, x, u=u, dt=settings.dt, sensors=SensorSet(name="added", sensors=(sensor,)), rng=rng)
    keys, channel = ["trajectory", "step"], sensor.channel
    new = table[keys].merge(added[[*keys, channel]], on=keys, how="left", validate="one_to_one")[channel]
    if channel in table:  # measured more often: the record's samples kept, the added ones between them
        new = table[channel].where(table[channel].notna(), new.to_numpy())
    return table.assign(**{channel: new.to_numpy()})


def record_settings(config: Mapping, sensors: str, case: str = "") -> tuple[SensorSet, SimulationSettings]:
    """A sensor set of ``discovery.sensor_sets`` and the simulation it measures (its length and operation);
    for a drawn ``case`` (``drawn<seed>``) under a set that varies, the record its seed draws
    (:meth:`costa.sensors.SensorSet.drawn`, from its own stream: the effect's draws are untouched)."""
    sensor_set = sensor_sets_from_config(config["discovery"]["sensor_sets"])[sensors]
    if sensor_set.vary is not None and (drawn := DRAWN_NAME.fullmatch(case)):
        sensor_set = sensor_set.drawn(seeds.numpy_generator(int(drawn.group(1)), 0, f"benchmark/record/{sensors}"))
    settings = SimulationSettings.from_config(config["simulation"])
    return sensor_set, replace(
        settings, steps=sensor_set.steps(settings.dt, settings.steps), operation=sensor_set.operation
    )


def simulated_cells(config: Mapping, case: HiddenEffectCase, sensors: str, split: str) -> tuple[np.ndarray, np.ndarray]:
    """The true states (n, K, 8) and inputs (n, K, 5) of a case's cells to learn from (``train``) or held out."""
    sensor_set, settings = record_settings(config, sensors, case.name)
    true, _ = case.models(model_from_config(config["physics"])[0])
    count = _counts(config["discovery"], sensor_set)[split]
    stream = f"discovery/{case.name}/{split}"
    trajectories, _ = simulate_set(
        true, settings, n_trajectories=count, seed=config["seed"], replicate=0, stream_name=stream, compiled=True
    )
    return trajectories.x, trajectories.u


def case_noise(true, x: np.ndarray, u: np.ndarray, sensor_set: SensorSet, level: float) -> dict[str, float]:
    """The noise std a channel that declares none gets: ``level`` times its std over the data."""
    values = observe(true, x, u, sensor_set.channels).reshape(-1, len(sensor_set.channels))
    return dict(zip(sensor_set.channels, level * values.std(axis=0), strict=True))


def simulated_data(config: Mapping, case: str, sensors: str = "full") -> str:
    """What a case's simulated data are, in words: its cells to learn from and held out (as
    :func:`case_tables` simulates them for the sensor set), their length where the set gives it, and
    the case's noise level where a channel of the set takes it (one that declares no noise of its own)."""
    discovery = config["discovery"]
    sensor_set, _ = record_settings(config, sensors, case)
    counts = _counts(discovery, sensor_set)
    length = f" of {sensor_set.hours:g} h" if sensor_set.hours else ""
    declared = all(s.noise is not None for s in sensor_set.sensors)
    noise = "" if declared else f" with {find_case(case).noise:.1%} measurement noise"
    drawn = f", its record drawn: {sensor_set.describe()}" if discovery["sensor_sets"][sensors].get("vary") else ""
    return f"{counts['train']} simulated trajectories{length} ({counts['held_out']} held out){noise}{drawn}"


def _counts(discovery: Mapping, sensor_set) -> dict[str, int]:
    """Trajectories to learn from and held out: the sensor set's, else the discovery's."""
    return {
        "train": sensor_set.trajectories or discovery["trajectories"],
        "held_out": sensor_set.held_out_trajectories or discovery["held_out_trajectories"],
    }
