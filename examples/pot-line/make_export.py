"""Make the pot-line example's historian files: one simulated pot, exported as a historian writes it.

    PYTHONPATH=src python examples/pot-line/make_export.py [--days 10] [--case alumina_feeder] [--folder DIR]
        [--anode-change-hours H]

One pot run as a pot line runs it (the ``pot_line`` operation: current held, alumina fed on the
voltage), with a hidden effect (default: the alumina feeder delivers 92 % of its command; or
``no_effect``), written to ``examples/pot-line/data/`` (or ``--folder``) as:

- ``export.csv``: the pot voltage, the line current and the anode-cathode distance the pot controller
  tracks as it moves the beam (cm), long (timestamp, tag, value, quality), in
  local time (Europe/Oslo), stamped 0-3 s late, with a 30 min outage of all three on day 2, a 2 min
  anode effect (30 V) on day 3, ten values sent twice, a few of bad quality and a setpoint tag;
- ``lab.csv``: the bath temperature, the excess AlF3 (%) and the metal height (cm) once a day,
  reported 4 h after sampling;
- ``events.csv``: the feeder's shots, the AlF3 additions and the taps (t) as the controllers made them,
  and, with ``--anode-change-hours``, a new anode (900 kg of carbon, set cold) every H hours from the
  start (``simulation.pot_line.anode_change_s``: the heat it takes from the bath is simulated, not modelled).
"""

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

from costa import seeds
from costa.config import DEFAULT_CONFIG, load_config
from costa.discover.cases.tables import case_table
from costa.discover.cases.unshipped import find_case

HERE = Path(__file__).resolve().parent
START = pd.Timestamp("2026-03-02 06:00:00", tz="Europe/Oslo")  # written in local time, as the clocks read
CATHODE_AREA = 12.0  # m2: the tag map's, metal mass = 2300 kg/m3 x area x height


def _stamps(seconds: np.ndarray, rng: np.random.Generator) -> pd.Series:
    late = rng.uniform(0.0, 3.0, seconds.shape)
    return _local(START + pd.to_timedelta(seconds + late, unit="s")).str[:-3]


def _local(times) -> pd.Series:
    """Times as the pot line's clocks wrote them: local, without an offset (an hour skipped in spring)."""
    return pd.Series(pd.DatetimeIndex(times).tz_convert("Europe/Oslo").strftime("%Y-%m-%d %H:%M:%S.%f"))


def _events(u: np.ndarray, dt: float, column: int, tag: str, per_t: float) -> pd.DataFrame:
    """Each stretch of steps where input ``column`` is fed, as one event of its total amount."""
    fed = u[:, column] > 0
    starts = np.flatnonzero(fed & ~np.r_[False, fed[:-1]])
    ends = np.flatnonzero(fed & ~np.r_[fed[1:], False])
    amount = np.array([u[a : b + 1, column].sum() * dt for a, b in zip(starts, ends, strict=True)]) / per_t
    return pd.DataFrame({"seconds": starts * dt, "tag": tag, "amount": amount, "duration_s": (ends - starts + 1) * dt})


def main(days: float, case: str, folder: Path, anode_change_hours: float) -> None:
    config = load_config(DEFAULT_CONFIG, overrides={
        "simulation": {"pot_line": {"anode_change_s": 3600.0 * anode_change_hours}},
        "discovery": {"sensor_sets": {"pot_line": {"hours": 24.0 * days, "trajectories": 1, "held_out_trajectories": 1}}},
    })  # fmt: skip
    train = case_table(config, find_case(case), "pot_line", "train")
    u, dt = train[["u1", "u2", "u3", "u4", "u5"]].to_numpy(), config["simulation"]["dt_s"]
    rng = seeds.numpy_generator(config["seed"], 0, "examples/pot-line/export")
    seconds = train["time_s"].to_numpy()
    keep = ~((seconds >= 30 * 3600) & (seconds < 30.5 * 3600))  # the outage: no value of either tag
    volts = train["U_pot"].to_numpy().copy()
    volts[(seconds >= 50 * 3600) & (seconds < 50 * 3600 + 120)] = 30.0  # an anode effect
    export = pd.concat([
        pd.DataFrame({"timestamp": _stamps(seconds[keep], rng), "tag": "POT12.VOLT", "value": volts[keep].round(4)}),
        pd.DataFrame({"timestamp": _stamps(seconds[keep], rng), "tag": "LINE.AMPS", "value": (u[keep, 1] / 1e3).round(3)}),
        pd.DataFrame({"timestamp": _stamps(seconds[keep], rng), "tag": "POT12.ACD", "value": (u[keep, 4] * 100).round(3)}),
    ]).assign(quality="good").sort_values("timestamp", kind="stable", ignore_index=True)  # fmt: skip
    export.loc[rng.choice(len(export), 5, replace=False), "quality"] = "bad"
    setpoint = export.iloc[::8640].assign(tag="POT12.SETPOINT", value=4.25)
    export = pd.concat([export, export.iloc[rng.choice(len(export), 10, replace=False)], setpoint])
    export = export.sort_values(["timestamp", "tag"], kind="stable")
    lab = []
    for channel, tag, scale in (
        ("x6", "BATH_TEMP", 1.0),
        ("c3", "XS_ALF3", 100.0),
        ("x5", "METAL_HEIGHT", 100 / (2300 * CATHODE_AREA)),
    ):
        sampled = train[channel].notna().to_numpy()
        stamps = START + pd.to_timedelta(seconds[sampled], unit="s")
        lab.append(pd.DataFrame({"sample_time": _local(stamps).str[:-7], "report_time": _local(stamps + pd.Timedelta(hours=4)).str[:-7], "tag": tag,
                                 "value": (train[channel][sampled] * scale).round(4).to_numpy()}))  # fmt: skip
    changes = np.arange(1, days * 24 / anode_change_hours) * anode_change_hours * 3600 if anode_change_hours else []
    anodes = pd.DataFrame({"seconds": changes, "tag": "ANODE_SET", "amount": config["simulation"]["pot_line"]["anode_kg"],
                           "duration_s": 0.0})  # fmt: skip
    events = pd.concat([_events(u, dt, 0, "FEEDER_SHOT", 1.0), _events(u, dt, 2, "ALF3_ADD", 1.0),
                        _events(u, dt, 3, "TAP", 1000.0), anodes]).sort_values("seconds", kind="stable")  # fmt: skip
    events.insert(0, "timestamp", _local(START + pd.to_timedelta(events.pop("seconds"), unit="s")).str[:-7].to_numpy())
    folder.mkdir(parents=True, exist_ok=True)
    export.to_csv(folder / "export.csv", index=False)
    pd.concat(lab).sort_values("sample_time").to_csv(folder / "lab.csv", index=False)
    events.to_csv(folder / "events.csv", index=False, float_format="%.6g")
    print(f"{case}: {days:g} days, {len(export)} export rows, {len(events)} events in {folder}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--days", type=float, default=10.0)
    parser.add_argument("--case", default="alumina_feeder")
    parser.add_argument("--folder", type=Path, default=HERE / "data")
    parser.add_argument("--anode-change-hours", type=float, default=0.0, help="a new anode every H hours (0: none)")
    main(**vars(parser.parse_args()))
