"""The closed loop of "what to measure next": the channel added to a record, the recommendation chosen,
and what was predicted set beside what was achieved."""

from __future__ import annotations

import copy

import numpy as np
import pandas as pd
import pytest

from costa.benchmark.closed_loop import (
    achieved_separation,
    loop_markdown,
    loop_row,
    loop_summary,
    loop_table,
    top_recommendation,
)
from costa.discover.cases.tables import case_tables, simulated_cells, with_channel
from costa.discover.cases.unshipped import find_case
from costa.sensors import Sensor


def _findings(named=(), outcome="not identifiable", gains=None, recommended=()):
    """A sparse run's findings as the loop reads them: its first round's candidates and recommendations."""
    gains = gains or {"part:a": 100.0, "part:b": 95.0}
    (best, best_gain), *others = gains.items()
    return {
        "named": list(named), "outcome": outcome, "accepted": ["part:b"], "flagged_channels": ["x6"],
        "rounds": [{
            "correction": {"hypothesis": best, "bic_gain": best_gain},
            "equivalent": [{"hypothesis": k, "bic_gain": g} for k, g in others],
            "alternatives": [], "not_fitted": [], "measure_next": list(recommended),
        }],
    }  # fmt: skip


RECOMMENDED = {"channel": "x5", "every_s": 28800, "noise": 15, "separation_noise_stds": 9.0, "rival": "part:b",
               "name_probability": 0.8, "right_name_probability": 0.4}  # fmt: skip


def test_the_loop_adds_the_first_recommendation_of_a_run_without_a_name():
    found = _findings(recommended=[{"channel": "x8", "every_s": 600}, {"channel": "x6", "every_s": 3600}])
    assert top_recommendation(found)["channel"] == "x8"
    assert top_recommendation({**found, "named": ["part:a"]}) is None and top_recommendation(_findings()) is None
    longer = {"channel": None, "every_s": None, "multiple": 4}  # more of the same: not simulated by the loop
    assert top_recommendation(_findings(recommended=[longer])) is None


def test_the_achieved_separation_is_the_added_records_share_of_the_bic_difference():
    """Before: part:a leads part:b by 5 of BIC; after: part:b leads by 95, a move of 100 = 10^2 noise stds."""
    before = _findings()
    after = _findings(gains={"part:b": 195.0, "part:a": 100.0})
    assert achieved_separation(before, after, "part:a", "part:b") == pytest.approx(10.0)
    assert np.isnan(achieved_separation(before, _findings(gains={"part:c": 1.0}), "part:a", "part:b"))


def test_the_loop_counts_the_right_names_it_gained_against_those_it_predicted():
    before = _findings(recommended=[RECOMMENDED])
    right = _findings(named=["part:b"], outcome="found", gains={"part:b": 195.0, "part:a": 100.0})
    wrong = _findings(named=["part:a"], outcome="found", gains={"part:a": 200.0, "part:b": 95.0})
    rows = [
        loop_row("drawn1", "partial", before, RECOMMENDED, right),
        loop_row("drawn2", "partial", before, RECOMMENDED, wrong),
        loop_row("drawn3", "partial", before, None, None),
        loop_row("drawn4", "partial", right, None, None),  # named: not for the loop to decide
    ]
    table = loop_table(rows)
    assert table["before"].tolist() == ["not identifiable, truth listed"] * 3 + ["right"]
    assert table["after"].tolist()[:2] == ["right", "wrong"] and table.added.isna().tolist() == [
        False,
        False,
        True,
        True,
    ]
    summary = loop_summary(table).iloc[0]
    assert (summary.undecided, summary.measurement_added, summary.names_given) == (3, 2, 2)
    assert (summary.right_gained, summary.wrong_gained, summary.names_predicted) == (1, 1, pytest.approx(1.6))
    assert summary.right_predicted == pytest.approx(0.8)
    assert summary.median_achieved_separation == pytest.approx(10.0)  # both moved the difference by 100
    page = loop_markdown(loop_summary(table), table, "test")
    assert (
        "| partial | 3 | 2 | 1.6 / 2 | 0.8 / 1 [" in page
        and "| drawn3 | partial | not identifiable, truth listed | nothing" in page
    )


def test_an_unexplained_run_is_judged_on_the_explanations_its_recommendation_separates():
    """Unexplained, no correction applied: the achieved separation is read between the recommendation's best and
    rival (their BIC difference moved from 5 to -95)."""
    before = _findings(outcome="unexplained")
    before["rounds"][0]["correction"] = None
    before["rounds"][0]["alternatives"] = [{"hypothesis": "part:a", "bic_gain": 100.0}]
    row = loop_row(
        "drawn1", "plant", before, RECOMMENDED | {"best": "part:a"}, _findings(gains={"part:b": 195.0, "part:a": 100.0})
    )
    assert row["achieved_separation"] == pytest.approx(10.0)


def test_a_channel_added_to_a_record_leaves_its_samples_as_they_were(default_config):
    """A shell thermocouple every 10 min and a bath dip every 10 min added to a plant record (10 s steps), whose
    bath is dipped hourly: the record's own samples untouched, the shell read every 60 steps from a phase of its
    own and the bath between the record's dips, each within its noise of the truth."""
    config = copy.deepcopy(default_config)
    config["discovery"]["sensor_sets"]["plant"] |= {"hours": 2, "trajectories": 3, "held_out_trajectories": 1}
    train, _ = case_tables(config, "paper_liquidus", "plant")
    shell = with_channel(config, "paper_liquidus", "plant", "train", train, Sensor("x8", 600, 2.0))
    bath = with_channel(config, "paper_liquidus", "plant", "train", train, Sensor("x6", 600, 1.5))
    pd.testing.assert_frame_equal(shell[train.columns], train)
    pd.testing.assert_frame_equal(bath[train.columns.drop("x6")], train.drop(columns="x6"))
    kept = train.x6.notna()
    assert (bath.x6[kept] == train.x6[kept]).all() and kept.sum() == 3 * 2
    assert (shell.x8.notna().groupby(shell.trajectory).sum() == 12).all()  # 720 steps, one in 60
    assert bath.x6.notna().sum() > 3 * 11  # the hourly dips and the 10-min ones between them
    x, _ = simulated_cells(config, find_case("paper_liquidus"), "plant", "train")
    for table, state, noise in ((shell, 7, 2.0), (bath, 5, 1.5)):
        column = table[["x8", "x6"][state == 5]].to_numpy()
        read = np.isfinite(column)
        assert np.all(np.abs(column[read] - x[..., state].ravel()[read]) < 6 * noise)
