"""A pot line: its pots screened with the starting model, grouped by how they disagree, pooled by group."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from conftest import snakemake

from costa.config import ConfigError, load_config
from costa.discover.pipeline import settings_from_config, starting_model
from costa.line.groups import group_meta, group_pots, line_page, line_table, pooled_record
from costa.line.pots import Line, pot_record
from costa.line.screen import screen_pot, signature


def _screen(**flags) -> dict:
    """A hand-made screen: channel -> bias (None: agrees)."""
    channels = [
        {"channel": c, "samples": 10, "chi2_per_dof": 1.0 if b is None else 30.0, "z": 0.0, "bias": b or 0.0,
         "bias_z": 0.0, "whiteness_z": 0.0, "flagged": b is not None}
        for c, b in flags.items()
    ]  # fmt: skip
    return {"hours": 120.0, "channels": channels, "flagged": [c["channel"] for c in channels if c["flagged"]],
            "signature": signature(channels)}  # fmt: skip


def test_pots_that_disagree_in_the_same_channels_with_the_same_signs_are_one_group():
    screens = {
        "p0": _screen(x5=None, U_pot=None),
        "p1": _screen(x5=0.4, U_pot=None),
        "p2": _screen(x5=0.3, U_pot=-0.1),
        "p3": _screen(x5=0.2, U_pot=None),
        "p4": _screen(x5=-0.2, U_pot=None),
    }
    assert [s["signature"] for s in screens.values()] == ["", "x5+", "x5+ U_pot-", "x5+", "x5-"]
    assert group_pots(screens) == [
        {"group": "A", "signature": "x5+", "pots": ["p1", "p3"]},
        {"group": "B", "signature": "x5+ U_pot-", "pots": ["p2"]},
        {"group": "C", "signature": "x5-", "pots": ["p4"]},
    ]
    table = line_table(screens, {"p1": "tapping_shortfall"})
    assert len(table) == 10 and set(table.columns) >= {"pot", "channel", "chi2_per_dof", "flagged", "signature"}
    assert table.loc[table.pot == "p1", "hidden"].tolist() == ["tapping_shortfall"] * 2


def test_a_groups_pots_are_pooled_as_the_trajectories_of_one_data_set():
    records = [
        pd.DataFrame({"trajectory": 7, "time_s": 10.0 * np.arange(n), "x5": 1.0 * i}) for i, n in enumerate((5, 4))
    ]
    pooled = pooled_record(records)
    assert pooled.groupby("trajectory").size().tolist() == [4, 4] and pooled.x5.tolist() == [0.0] * 4 + [1.0] * 4
    with pytest.raises(ValueError, match="one trajectory, this one 2"):
        pooled_record([pd.DataFrame({"trajectory": [0, 1], "time_s": [0.0, 0.0]})])


def test_a_simulated_line_names_its_pots_and_their_effects_and_judges_its_groups():
    line = Line.from_config({"name": "l", "starting_model": "full", "held_out_fraction": 0.34, "simulated": {
        "pots": 4, "sensors": "pot_line", "groups": [{"case": "tapping_shortfall", "pots": [1, 3]}]}})  # fmt: skip
    assert line.pots == ("pot00", "pot01", "pot02", "pot03") and line.simulated
    assert [line.effects[p] for p in line.pots] == ["no_effect", "tapping_shortfall", "no_effect", "tapping_shortfall"]
    meta = group_meta(line, {"group": "A", "signature": "x5+", "pots": ["pot01", "pot03"]})
    assert meta["accepted"] == ["input:u4"] and "(2 pots)" in meta["hidden"]
    mixed = group_meta(line, {"group": "B", "signature": "x5-", "pots": ["pot00", "pot01"]})
    assert "accepted" not in mixed  # pots hiding different things: nothing to judge the group by
    screens = {"pot00": _screen(x5=None), "pot01": _screen(x5=0.4), "pot02": _screen(x5=0.3), "pot03": _screen(x5=0.2)}
    groups = group_pots(screens)
    findings = {"A": {"outcome": "found", "named": ["input:u4"], "accepted": ["input:u4"], "flagged_channels": ["x5"],
                      "rounds": [{"correction": {"closed_form": "-0.1"}}]}}  # fmt: skip
    page = line_page(line, line_table(screens, line.effects), groups, findings)
    assert "Pots hiding nothing: 2, flagged 1 (pot02)." in page
    assert "tapping_shortfall (pot01, pot03): in group A; A: right." in page
    assert "| A | pot01, pot02, pot03 | found | input:u4 | -0.1 |" in page


def test_a_lines_config_is_checked_across_keys(default_config):
    base = {"name": "l", "simulated": {"pots": 4, "sensors": "pot_line", "groups": []}}
    for change, message in (
        ({"sensors": "daily"}, "line.simulated.sensors 'daily' is not in discovery.sensor_sets"),
        ({"groups": [{"case": "feeder", "pots": [1]}]}, r"line.simulated.groups\[0\].case 'feeder' is not a shipped"),
        ({"groups": [{"case": "no_effect", "pots": [4]}]}, "pot 4 is beyond the line's 4 pots"),
        ({"groups": [{"case": "no_effect", "pots": [1]}, {"case": "top_heat_loss", "pots": [1]}]}, "a pot hides one"),
    ):
        with pytest.raises(ConfigError, match=message):
            load_config(overrides={"line": {**base, "simulated": {**base["simulated"], **change}}})
    with pytest.raises(ConfigError, match="line"):
        load_config(overrides={"line": {"name": "l"}})  # neither simulated nor records


def test_a_pot_that_hides_nothing_agrees_and_one_tapped_short_disagrees_in_its_metal(default_config):
    """Each pot is one cell of its own (its own start, inputs and noise): a pot line's 5-day record
    of a pot hiding nothing passes the starting model's channel tests; one tapped 10 % short is
    flagged in the metal, above the model (more metal left in the pot)."""
    line = Line.from_config({"name": "t", "starting_model": "full", "held_out_fraction": 0.34, "simulated": {
        "pots": 2, "sensors": "pot_line", "groups": [{"case": "tapping_shortfall", "pots": [1]}]}})  # fmt: skip
    model, settings = starting_model(default_config, "full"), settings_from_config(default_config)
    records = {pot: pot_record(default_config, line, pot) for pot in line.pots}
    assert not records["pot00"][["U_pot"]].equals(records["pot01"][["U_pot"]])
    screens = {
        pot: screen_pot(model, r, line.declared_noise(default_config), settings, pot) for pot, r in records.items()
    }
    assert screens["pot00"]["signature"] == "" and screens["pot01"]["signature"].startswith("x5+")


@pytest.mark.integration
def test_a_small_simulated_line_runs_through_the_workflow(tmp_path):
    """Four pots of 60 h, two tapped short: screened, grouped, each group searched, the page written."""
    config = tmp_path / "line.yaml"
    config.write_text(
        "output: {results: results/tinyline, report: results/tinyline/report}\n"
        "discovery:\n  sensor_sets:\n    short_line: {operation: pot_line, hours: 60, gap_restart_hours: 24,\n"
        "      channels: {U_pot: {every_s: 10, noise: 0.005}, x6: {every_s: 28800, noise: 1.5},\n"
        "                 c3: {every_s: 28800, noise: 0.002}, x5: {every_s: 28800, noise: 15}}}\n"
        "line: {name: tiny, simulated: {pots: 4, sensors: short_line, groups: [{case: tapping_shortfall, pots: [1, 2]}]}}\n"
    )
    result = snakemake(tmp_path, "results/tinyline/line/tiny/line.md", "--configfile", str(config), check=False)
    assert result.returncode == 0, result.stderr[-4000:]
    root = tmp_path / "results/tinyline/line/tiny"
    groups = json.loads((root / "groups.json").read_text())
    assert all(set(g["pots"]) <= {"pot01", "pot02"} for g in groups)  # the pots hiding nothing agree
    page = (root / "line.md").read_text()
    assert "Pots hiding nothing: 2, flagged 0." in page and (root / "line.png").exists()
