"""A historian's export onto the model's step: the data contract's tables, and one line for a bad export."""

from __future__ import annotations

import json
import sys

import numpy as np
import pandas as pd
import pytest

from costa.data import TrajectoryDataError
from costa.events import load_trajectories_with_events
from costa.historian import ExportError, GridSettings, import_historian, read_tag_map
from costa.historian.report import write_import

TAGS = """\
signals:
  POT.VOLT: {to: U_pot, unit: V}
  LINE.AMPS: {to: u2, unit: kA}
  BATH: {to: x6, unit: degF}
  XS_ALF3: {to: c3, unit: percent}
  METAL: {to: x5, unit: cm}
events:
  SHOT: {kind: alumina_dose, unit: kg}
  TAP: {kind: tap, unit: t}
ignore: [POT.SETPOINT]
cathode_area_m2: 12.0
good_quality: [good, "192"]
"""
START = pd.Timestamp("2026-03-01 06:00:00")  # local time in Oslo: 05:00 UTC
#: the pot-line example's outcome (examples/pot-line/README.md): the feeder's gain named in 10 days
EXAMPLE_OUTCOME, EXAMPLE_NAMED = "found", ["input:u1"]


def _stamp(seconds: float) -> str:
    return (START + pd.Timedelta(seconds=seconds)).strftime("%Y-%m-%d %H:%M:%S.%f")


def _export(rows: list[tuple]) -> str:
    return "timestamp,tag,value,quality\n" + "".join(f"{_stamp(t)},{tag},{v},{q}\n" for t, tag, v, q in rows)


def _good_rows() -> list[tuple]:
    """3 h of voltage and current every 5 s, a 30 min outage of both from 1 h, a 2 min stale current
    at 2 h 30 min, an anode effect (25 V) for 60 s at 2 h, a duplicate, a bad-quality value, a setpoint."""
    rows = []
    for t in range(0, 3 * 3600, 5):
        if 3600 <= t < 5400:
            continue
        if not 9000 <= t < 9120:
            rows.append((t, "LINE.AMPS", 140.0 + (t % 10) / 10, "192"))
        rows.append((t, "POT.VOLT", 25.0 if 7200 <= t < 7260 else 4.2, "good"))
    rows.insert(3, rows[2])  # the same value twice
    rows.insert(5, (10, "POT.VOLT", 99.0, "bad"))
    rows.insert(7, (10, "POT.SETPOINT", 4.1, "good"))
    return rows


LAB = "sample_time,report_time,tag,value\n" + "\n".join(
    [f"{_stamp(1800)},{_stamp(5 * 3600)},BATH,1778.0", f"{_stamp(7500)},{_stamp(9 * 3600)},XS_ALF3,11.5",
     f"{_stamp(8000)},{_stamp(9 * 3600)},METAL,20.0"]
)  # fmt: skip
EVENTS = "timestamp,tag,amount,duration_s,weighed\n" + "\n".join(
    [f"{_stamp(600)},SHOT,1.8,0,", f"{_stamp(4000)},SHOT,1.8,0,", f"{_stamp(6000)},TAP,1.2,600,1.19"]
)


@pytest.fixture
def files(tmp_path):
    def write(export=None, tags=TAGS, lab=LAB, events=EVENTS):
        paths = {}
        for name, text in (("export.csv", export or _export(_good_rows())), ("tags.yaml", tags), ("lab.csv", lab),
                           ("events.csv", events)):  # fmt: skip
            (tmp_path / name).write_text(text)
            paths[name.split(".")[0]] = tmp_path / name
        return paths

    return write


def _import(paths, **settings):
    grid = GridSettings(timezone="Europe/Oslo", **settings)
    return import_historian(paths["export"], read_tag_map(paths["tags"]), grid, paths["events"], paths["lab"])


def test_an_export_becomes_the_data_contracts_record_and_events(files, tmp_path):
    """Stamps in Oslo's winter time are UTC + 1; values averaged within a 10 s step; the outage
    (longer than max_gap_s) cuts the record, the 2 min stale current is held; the anode effect's
    voltage is left out to 10 min after it; a lab value goes where it was sampled, in the model's
    units (1778 degF = 970 degC; 11.5 % = 0.115; 20 cm of metal on 12 m2 = 5520 kg; 1.2 t = 1200 kg);
    the feeder shot in the outage is left out.  The tables pass the contract's own checks."""
    imported = _import(files())
    record, report, events = imported.record, imported.report, imported.events
    assert report["start_utc"] == "2026-03-01 05:00:00+00:00"
    assert report["trajectories"] == 2 and report["cuts"] == [
        {"start_utc": "2026-03-01 06:00:00+00:00", "seconds": 1800.0}
    ]
    assert report["held_steps"] == {"u2": 12}
    first = record[record.time_s == 0].iloc[0]
    assert first.u2 == pytest.approx(140_250.0) and first.U_pot == pytest.approx(4.2)  # (140.0 + 140.5) / 2 kA
    assert report["bad_quality"] == {"POT.VOLT": 1} and report["tags"]["LINE.AMPS"]["duplicates"] == 1
    effect = record[(record.time_s >= 7200) & (record.time_s < 7260 + 600)]
    assert effect.U_pot.isna().all() and record[record.time_s == 7260 + 610].U_pot.notna().all()
    assert report["anode_effects"] == [{"voltage": "U_pot", "start_utc": "2026-03-01 07:00:00+00:00", "seconds": 60.0}]
    assert record.loc[record.time_s == 1800, "x6"].item() == pytest.approx(970.0)
    assert record.loc[record.time_s == 7500, "c3"].item() == pytest.approx(0.115)
    assert record.loc[record.time_s == 8000, "x5"].item() == pytest.approx(2300 * 12.0 * 0.20)
    assert list(events.kind) == ["alumina_dose", "tap"] and list(events.time_s) == [600.0, 6000.0]
    assert (
        list(events.trajectory) == [0, 1] and list(events.amount_kg) == [1.8, 1200.0] and events.weighed_kg[1] == 1190.0
    )
    assert report["events"]["alumina_dose"] == {"placed": 1, "left_out": 1}  # the second shot fell in the outage
    write_import(imported, tmp_path / "out", {"test": True})
    table = load_trajectories_with_events(tmp_path / "out/record.parquet", tmp_path / "out/events.csv", {"u5": 0.05})
    assert table.u1.sum() * 10.0 == pytest.approx(1.8) and table.u4.sum() * 10.0 == pytest.approx(1200.0)
    assert (tmp_path / "out/channels.png").stat().st_size > 0 and "Anode effects" in (
        tmp_path / "out/import.md"
    ).read_text()


def test_an_anode_change_cuts_the_record_where_asked_and_feeds_nothing(files):
    """With ``anode_change_after_s``, a new anode (an event of kind ``anode_change``) ends its stretch at
    its step and the next starts that long after (from the state the estimator finds there); the event
    then lies in the cut.  Without it the record runs through, the event placed."""
    tags = TAGS.replace(
        "  TAP: {kind: tap, unit: t}\n", "  TAP: {kind: tap, unit: t}\n  ANODE: {kind: anode_change, unit: kg}\n"
    )
    rows = _import(files()).report["rows"]
    spoilt = files(tags=tags, events=EVENTS + f"\n{_stamp(9600)},ANODE,900,0,")
    cut = _import(spoilt, anode_change_after_s=600)
    record, report = cut.record, cut.report
    assert report["trajectories"] == 3 and report["rows"] == rows - 60
    assert record[record.trajectory == 1].time_s.max() == 9600 - 10
    assert record[record.trajectory == 2].time_s.min() == 9600 + 600
    assert report["anode_change_cuts"] == 1 and report["events"]["anode_change"] == {"placed": 0, "left_out": 1}
    through = _import(spoilt)
    assert through.report["trajectories"] == 2 and through.report["anode_change_cuts"] == 0
    assert list(through.events.kind) == ["alumina_dose", "tap", "anode_change"]


def test_a_wide_export_reads_as_the_long_one(files):
    """A wide export (a column a tag, empty where a tag has no value) gives the same record."""
    long = pd.read_csv(files()["export"])
    good = long[long.quality.isin(["good", "192"])].drop_duplicates(["timestamp", "tag"])
    wide = good.pivot(index="timestamp", columns="tag", values="value").reset_index()
    assert_frame = _import(files(export=wide.to_csv(index=False))).record
    expected = _import(files()).record
    pd.testing.assert_frame_equal(assert_frame, expected)


def _spoil_row(row: int, **changes) -> str:
    rows = _good_rows()
    t, tag, value, quality = rows[row]
    rows[row] = (changes.get("t", t), changes.get("tag", tag), changes.get("value", value), quality)
    return _export(rows)


BAD = [
    ("unknown tag", {"export": _spoil_row(20, tag="POT.NOISE")}, "export.csv: tag 'POT.NOISE' at row 20 is not in the tag map"),
    ("text for a value", {"export": _spoil_row(8, value="four")}, "export.csv: tag 'POT.VOLT' at row 8 has 'four' in 'value', not a number"),
    ("time going backwards", {"export": _spoil_row(30, t=-600)}, "export.csv: tag 'POT.VOLT' at row 30 goes back in time"),
    ("a stamp that is not a time", {"export": _export(_good_rows()).replace(_stamp(100), "yesterday", 1)},
     "export.csv: column 'timestamp' at row 43 is not a time: 'yesterday'"),
    ("a stamp in the hour the clocks skip", {"export": _export(_good_rows()).replace(_stamp(100), "2026-03-29 02:30:00", 1)},
     "export.csv: column 'timestamp' at row 43: 2026-03-29 02:30:00 is not one time in Europe/Oslo"),
    ("no timestamp column", {"export": "tag,value\nPOT.VOLT,4.2\n"}, "export.csv: no column 'timestamp' or 'time'"),
    ("a unit that does not convert", {"tags": TAGS.replace("{to: x6, unit: degF}", "{to: x6, unit: kg}")},
     "tags.yaml: signal 'BATH' in kg does not convert to x6's unit degC"),
    ("a unit pint does not know", {"tags": TAGS.replace("unit: kA", "unit: kiloamps_x")},
     "tags.yaml: tag 'LINE.AMPS' has the unit 'kiloamps_x', which pint does not know"),
    ("an event of unknown kind", {"tags": TAGS.replace("kind: tap", "kind: crust_break")},
     "tags.yaml: event 'TAP' has unknown kind 'crust_break'; known: tap, alf3_addition, alumina_dose, anode_change"),
    ("an unknown target", {"tags": TAGS.replace("to: U_pot", "to: voltage")}, "tags.yaml: signal 'POT.VOLT' maps to unknown target 'voltage'"),
    ("no line current", {"tags": TAGS.replace("  LINE.AMPS: {to: u2, unit: kA}\n", "")},
     "tags.yaml: no tag is mapped to u2 (the line current)"),
    ("a metal height without the cathode's area", {"tags": TAGS.replace("cathode_area_m2: 12.0\n", "")},
     "tags.yaml: signal 'METAL' logs x5 (metal mass) as a height in cm: give cathode_area_m2"),
    ("two tags for one channel", {"tags": TAGS.replace("  METAL:", "  VOLT2: {to: U_pot, unit: mV}\n  METAL:")},
     "tags.yaml: tags ['POT.VOLT', 'VOLT2'] are all mapped to 'U_pot'"),
    ("a lab sample with no sample time", {"lab": LAB.replace(_stamp(7500) + ",", ",", 1)},
     "lab.csv: column 'sample_time' has no time at row 1"),
    ("a lab sample reported before it was taken", {"lab": LAB.replace(_stamp(5 * 3600), _stamp(0), 1)},
     "lab.csv: tag 'BATH' at row 0 was reported"),
    ("a lab tag that is not a signal", {"lab": LAB.replace("XS_ALF3", "SHOT")}, "lab.csv: tag 'SHOT' at row 1 is an event"),
    ("an event tag not in the map", {"events": EVENTS.replace(",TAP,", ",CRANE,")}, "events.csv: tag 'CRANE' at row 2 is not in the tag map"),
    ("an event with no amount", {"events": EVENTS.replace("SHOT,1.8,0,\n", "SHOT,,0,\n", 1)}, "events.csv: event 'SHOT' at row 0 has no amount"),
]  # fmt: skip


@pytest.mark.parametrize(("spoilt", "message"), [pytest.param(s, m, id=n) for n, s, m in BAD])
def test_a_bad_export_stops_with_one_message_naming_file_tag_and_row(files, spoilt, message):
    with pytest.raises(TrajectoryDataError) as raised:
        _import(files(**spoilt))
    assert message in str(raised.value) and "\n" not in str(raised.value), str(raised.value)


def test_export_errors_are_data_errors_the_workflow_reports_in_one_line():
    assert issubclass(ExportError, TrajectoryDataError)


def test_a_short_input_gap_is_held_and_a_long_one_cut_whole(files):
    """max_gap_s sets which outages are bridged: at 20 min the 2 min stale current is held, the
    30 min outage is cut whole (no step of it held); at 40 min the outage is held too, one trajectory."""
    report = _import(files(), max_gap_s=1200).report
    assert report["trajectories"] == 2 and report["held_steps"] == {"u2": 12}
    report = _import(files(), max_gap_s=2400).report
    assert report["trajectories"] == 1 and report["held_steps"] == {"u2": 12 + 180} and not report["cuts"]
    assert np.isclose(report["rows"], report["steps"])


def test_the_hour_an_autumn_clock_change_repeats_is_read_in_order(files):
    """Local stamps across 25 October 2026 in Oslo (03:00 summer time -> 02:00 winter time): the
    repeated hour's stamps, in time order, are two different hours in UTC, one record without a gap."""
    rows = [(t, tag, v, "good") for t in range(0, 4 * 3600, 10) for tag, v in (("LINE.AMPS", 140.0), ("POT.VOLT", 4.2))]
    local = pd.Timestamp("2026-10-25 00:00", tz="UTC") + pd.to_timedelta([t for t, *_ in rows], unit="s")
    stamps = local.tz_convert("Europe/Oslo").strftime("%Y-%m-%d %H:%M:%S")
    export = "timestamp,tag,value,quality\n" + "".join(
        f"{s},{tag},{v},{q}\n" for s, (_, tag, v, q) in zip(stamps, rows, strict=True)
    )
    paths = files(export=export)
    grid = GridSettings(timezone="Europe/Oslo")
    imported = import_historian(paths["export"], read_tag_map(paths["tags"]), grid)
    assert imported.report["start_utc"] == "2026-10-25 00:00:00+00:00" and imported.report["trajectories"] == 1
    assert imported.report["rows"] == 4 * 360 and not imported.report["cuts"]


@pytest.mark.parametrize(("seconds", "trajectories", "left_over"), [(1800, 5, 0), (2400, 3, 120 + 60)])
def test_stretches_are_cut_into_whole_trajectories_of_equal_length(files, seconds, trajectories, left_over):
    """trajectory_s cuts the 1 h before the outage and the 1.5 h after it into whole pieces (what
    discovery stacks: equal lengths); what does not make a whole piece is left out and counted."""
    imported = _import(files(), trajectory_s=seconds)
    lengths = imported.record.groupby("trajectory").size()
    assert len(lengths) == trajectories and (lengths == seconds // 10).all()
    assert imported.report["left_over_steps"] == left_over and imported.report["trajectories"] == trajectories


@pytest.mark.integration  # about four minutes: ten days of one pot simulated, imported and searched
def test_the_pot_line_example_runs_from_its_two_commands(tmp_path):
    """examples/pot-line/README.md: the export made, then one command imports it and runs discovery."""
    from conftest import REPOSITORY, repository_copy, run_command

    work = repository_copy(tmp_path / "repo")
    made = run_command(work, f"PYTHONPATH=src {sys.executable} examples/pot-line/make_export.py")
    assert made.returncode == 0, made.stderr
    target = "results/pot-line/discovery/pot12/findings.json"
    ran = run_command(work, f"snakemake --cores 2 {target} --configfile examples/pot-line/config.yaml")
    assert ran.returncode == 0, ran.stderr[-3000:]
    imported = json.loads((work / "results/pot-line/historian/pot12/import.json").read_text())
    assert imported["trajectories"] == 4 and len(imported["cuts"]) == 1 and len(imported["anode_effects"]) == 1
    found = json.loads((work / target).read_text())
    assert found["outcome"] == EXAMPLE_OUTCOME and found["named"] == EXAMPLE_NAMED, (found["outcome"], found["named"])
    assert REPOSITORY != work
