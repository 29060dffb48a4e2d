"""Taps, AlF3 additions and alumina doses as events: their rates on the record's grid carry their amounts."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from costa.data import TrajectoryDataError, to_table
from costa.events import load_trajectories_with_events

STEPS, DT = 360, 10.0  # two trajectories of an hour each


def _record(path, steps=STEPS, alumina_feed=0.0):
    """A 140 kA pot's record: inputs at every step (no tapping or AlF3 feed logged) and its bath temperature."""
    x = np.tile([3000.0, 500.0, 1800.0, 14000.0, 10000.0, 970.0, 820.0, 580.0], (2, steps, 1))
    u = np.tile([alumina_feed, 140_000.0, 0.0, 0.0, 0.05], (2, steps, 1))
    to_table(x, u, DT).drop(columns=["x1", "x2", "x3", "x4", "x5", "x7", "x8"]).to_csv(path, index=False)
    return path


def _load(tmp_path, rows, **record):
    events = tmp_path / "events.csv"
    pd.DataFrame(rows, columns=["trajectory", "time_s", "kind", "amount_kg", "duration_s"]).to_csv(events, index=False)
    return load_trajectories_with_events(_record(tmp_path / "cell.csv", **record), events)


def _rates(table, name):
    return table[name].to_numpy().reshape(2, -1)


def test_a_tap_is_spread_evenly_over_its_duration(tmp_path):
    """1000 kg over 10 min from 95 s: 1000/600 kg/s in every full step, half of it in the two half steps."""
    u4 = _rates(_load(tmp_path, [(1, 95.0, "tap", 1000.0, 600.0)]), "u4")
    full = 1000.0 / 600.0
    assert u4[1, 9] == pytest.approx(full / 2) and u4[1, 69] == pytest.approx(full / 2)
    np.testing.assert_allclose(u4[1, 10:69], full, rtol=1e-12)
    assert np.count_nonzero(u4[1]) == 61 and not u4[0].any()
    assert u4.sum() * DT == pytest.approx(1000.0, rel=1e-12)


def test_an_instant_dose_falls_into_its_step_and_adds_to_the_logged_feed(tmp_path):
    u1 = _rates(_load(tmp_path, [(0, 1234.0, "alumina_dose", 1.8, np.nan)], alumina_feed=0.5), "u1")
    assert u1[0, 123] == pytest.approx(0.5 + 1.8 / DT, rel=1e-12)
    assert (np.delete(u1, 123, axis=1) == 0.5).all()


def test_an_anode_change_feeds_nothing_and_is_said_not_modelled(tmp_path):
    """A new anode moves no input (the model has none for its heat); the findings' note counts those the
    record runs through."""
    from costa.events import not_modelled, read_events

    rows = [
        (0, 600.0, "anode_change", 900.0, 0),
        (1, 60.0, "alumina_dose", 1.8, 0),
        (1, 900.0, "anode_change", 900.0, 0),
    ]
    table = _load(tmp_path, rows)
    events = read_events(tmp_path / "events.csv")
    assert not_modelled(events).startswith("the events hold 2 anode changes, which the model does not describe")
    assert not_modelled(events.iloc[1:2]) == ""
    pd.testing.assert_frame_equal(table, _load(tmp_path, rows[1:2]))


def test_the_rates_integrate_to_the_amounts_over_the_grid(tmp_path):
    """Conservation, event by event summed per trajectory and kind: sum of rate x dt = sum of amounts."""
    rng = np.random.default_rng(7)
    rows = []
    for trajectory in (0, 1):
        for t in np.sort(rng.uniform(0, STEPS * DT - 3600, 40)):
            kind = rng.choice(["tap", "alf3_addition", "alumina_dose"])
            amount = {"tap": rng.uniform(500, 5000), "alf3_addition": rng.uniform(1, 100)}.get(kind, rng.uniform(1, 3))
            duration = rng.uniform(60, 3600) if kind == "tap" else rng.choice([0.0, rng.uniform(0, 3600)])
            rows.append((trajectory, t, kind, amount, duration))
    table = _load(tmp_path, rows)
    events = pd.DataFrame(rows, columns=["trajectory", "time_s", "kind", "amount_kg", "duration_s"])
    for kind, name in (("tap", "u4"), ("alf3_addition", "u3"), ("alumina_dose", "u1")):
        amounts = events[events.kind == kind].groupby("trajectory")["amount_kg"].sum().to_numpy()
        np.testing.assert_allclose(_rates(table, name).sum(axis=1) * DT, amounts, rtol=1e-12)
        assert (_rates(table, name) >= 0).all()


def test_a_days_tap_takes_out_the_metal_faraday_says_the_pot_made(tmp_path):
    """140 kA at 95 % current efficiency makes 1071 kg a day; tapping that much leaves the metal where it was."""
    from costa.config import load_config
    from costa.physics import model_from_config

    model = model_from_config(load_config(overrides={"physics": {"cell": {"current_efficiency": 0.95}}})["physics"])[0]
    made = model.params.k6 * 140_000 * 86_400
    assert made == pytest.approx(1071, abs=1)
    table = _load(tmp_path, [(0, 43_200.0, "tap", made, 900.0), (1, 0.0, "tap", made, 900.0)], steps=8640)
    x = np.tile([3000.0, 500.0, 1800.0, 14000.0, 10000.0, 970.0, 820.0, 580.0], (2, 8640, 1))
    u = table[["u1", "u2", "u3", "u4", "u5"]].to_numpy().reshape(2, 8640, 5)
    net = model.balance_flows(x, u)["metal_mass"].sum(axis=1) * DT  # kg over the day
    np.testing.assert_allclose(net, 0.0, atol=1e-9 * made)


BAD = [
    ("out of time order", [(0, 600.0, "alumina_dose", 1.8, 0), (0, 300.0, "alumina_dose", 1.8, 0)],
     "events.csv: column 'time_s' must not decrease within a trajectory; row 1 goes back from 600 to 300"),
    ("unknown kind", [(0, 60.0, "alumina_dose", 1.8, 0), (0, 90.0, "crust_break", 900.0, 0)],
     "events.csv: column 'kind' has the unknown kind 'crust_break' at row 1; known: tap, alf3_addition, alumina_dose, anode_change"),
    ("an anode of 9 kg (a t logged as kg)", [(0, 90.0, "anode_change", 0.9, 0)],
     "events.csv: column 'amount_kg' must lie in 300-2000 kg for kind 'anode_change', row 0 has 0.9"),
    ("negative amount", [(0, 60.0, "alf3_addition", 25.0, 0), (1, 60.0, "alf3_addition", -25.0, 0)],
     "events.csv: column 'amount_kg' must be positive, row 1 has -25"),
    ("tap after the record", [(1, 3000.0, "tap", 1100.0, 900.0)],
     "events.csv: column 'time_s' at row 0: the tap from 3000 s to 3900 s lies outside trajectory 1 of "),
    ("dose before the record", [(0, -10.0, "alumina_dose", 1.8, 0)],
     "events.csv: column 'time_s' at row 0: the alumina_dose at -10 s lies outside trajectory 0 of "),
    ("unknown trajectory", [(0, 60.0, "alumina_dose", 1.8, 0), (4, 60.0, "alumina_dose", 1.8, 0)],
     "events.csv: column 'trajectory' at row 1 names trajectory 4, which "),
    ("a tap in t logged as kg", [(0, 60.0, "tap", 1.07, 600.0)],
     "events.csv: column 'amount_kg' must lie in 100-5000 kg for kind 'tap', row 0 has 1.07"),
    ("a tap of no duration", [(0, 60.0, "tap", 1000.0, np.nan)],
     "events.csv: column 'duration_s' must lie in 60-3600 s for kind 'tap', row 0 has 0"),
    ("an AlF3 addition of 300 kg", [(0, 60.0, "alf3_addition", 300.0, 0)],
     "events.csv: column 'amount_kg' must lie in 0-100 kg for kind 'alf3_addition', row 0 has 300"),
]  # fmt: skip


@pytest.mark.parametrize(("rows", "message"), [pytest.param(r, m, id=n) for n, r, m in BAD])
def test_a_bad_event_is_named_by_file_column_and_row(tmp_path, rows, message):
    with pytest.raises(TrajectoryDataError) as error:
        _load(tmp_path, rows)
    assert str(error.value).startswith(f"{tmp_path}/{message}"), str(error.value)


def test_a_bad_events_file_stops_the_run_at_its_config_key(tmp_path):
    from costa.config import check_user_data, load_config

    events = tmp_path / "events.csv"
    events.write_text("trajectory,time_s,kind,amount_kg\n0,60,tapping,1000\n")
    user = {"path": str(_record(tmp_path / "cell.csv")), "events": str(events), "name": "cell"}
    with pytest.raises(TrajectoryDataError, match=r"^invalid data at 'discovery.user_data.events': .*events.csv: "):
        check_user_data(load_config(overrides={"discovery": {"user_data": user}}))


def test_a_weighed_tap_is_a_sample_of_the_tapping_that_reached_the_cell(tmp_path):
    """1000 kg ordered over 10 min from 95 s, 900 kg on the scale: one m_tap sample of 900/600 kg/s in a full step
    of the tap, against u4 = 1000/600 there; the unweighed tap gives none; a weight on a dose is refused."""
    events = tmp_path / "events.csv"
    pd.DataFrame(
        [(1, 95.0, "tap", 1000.0, 600.0, 900.0), (0, 95.0, "tap", 1000.0, 600.0, np.nan)],
        columns=["trajectory", "time_s", "kind", "amount_kg", "duration_s", "weighed_kg"],
    ).to_csv(events, index=False)
    table = load_trajectories_with_events(_record(tmp_path / "cell.csv"), events)
    weighed, u4 = _rates(table, "m_tap"), _rates(table, "u4")
    sampled = np.argwhere(np.isfinite(weighed))
    assert len(sampled) == 1 and sampled[0][0] == 1 and 10 <= sampled[0][1] < 69
    assert weighed[tuple(sampled[0])] == pytest.approx(0.9 * u4[tuple(sampled[0])], rel=1e-12)
    pd.DataFrame(
        [(0, 95.0, "alumina_dose", 1.8, 0.0, 1.8)],
        columns=["trajectory", "time_s", "kind", "amount_kg", "duration_s", "weighed_kg"],
    ).to_csv(events, index=False)
    with pytest.raises(TrajectoryDataError, match="'weighed_kg' has a value at row 0, a 'alumina_dose'"):
        load_trajectories_with_events(tmp_path / "cell.csv", events)
