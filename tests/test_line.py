"""A pot line: its pots screened with the starting model, grouped by how they disagree, pooled by group."""

from __future__ import annotations

import json
import re
import sys

import numpy as np
import pandas as pd
import pytest
from conftest import REPOSITORY, snakemake

from costa.config import ConfigError, load_config
from costa.data import write_trajectories
from costa.discover.cases.shipped import CASES
from costa.discover.pipeline import settings_from_config, starting_model
from costa.line.check import check_pots, differing_pots, explained_pots
from costa.line.groups import group_meta, group_pots, line_table, pooled_record
from costa.line.page import line_page
from costa.line.pooled import pool_again
from costa.line.pots import Line, pot_record
from costa.line.screen import screen_pot, signature


def _screen(best=None, **flags) -> dict:
    """A hand-made screen: channel -> bias (None: agrees); ``best``: what explains it, hypothesis -> gain
    (a hypothesis alone: gain 50)."""
    channels = [
        {"channel": c, "samples": 10, "chi2_per_dof": 1.0 if b is None else 30.0, "z": 0.0, "bias": b or 0.0,
         "bias_z": 0.0, "whiteness_z": 0.0, "flagged": b is not None}
        for c, b in flags.items()
    ]  # fmt: skip
    return {"hours": 120.0, "channels": channels, "flagged": [c["channel"] for c in channels if c["flagged"]],
            "signature": signature(channels),
            "best": [{"hypothesis": h, "gain": g} for h, g in ({best: 50.0} if isinstance(best, str) else best or {}).items()]}  # fmt: skip


def test_pots_that_one_hypothesis_explains_as_well_as_any_are_one_group_the_largest_first():
    """Within 10 of BIC (5 of log-likelihood) of a pot's best, its data cannot tell two hypotheses apart;
    the signs of the channels' bias are shown, not grouped by (under a pot line's controllers one feeder
    fault biased the bath temperature up in one pot and down in another)."""
    screens = {
        "p0": _screen(x5=None, U_pot=None),
        "p1": _screen({"input:u4": 60.0, "term:metal_mass": 58.0}, x5=0.4, U_pot=None),
        "p2": _screen("input:u1", x5=0.3, U_pot=-0.1),
        "p3": _screen({"transfer:ledge_mass->metal_mass": 111.0, "input:u4": 107.0}, x5=0.2, U_pot=None),
        "p4": _screen({"input:u1": 900.0, "input:u4": 894.0}, x5=-0.2, U_pot=0.1),
        "p5": _screen(None, x5=None, U_pot=0.3),
        "p6": _screen({"term:metal_mass": 70.0, "input:u4": 64.0}, x5=0.2, U_pot=None),
    }
    assert [s["signature"] for s in screens.values()] == ["", "x5+", "x5+ U_pot-", "x5+", "x5- U_pot+", "U_pot+", "x5+"]
    assert group_pots(screens, equivalence=10.0) == [
        {"group": "A", "hypothesis": "input:u4", "pots": ["p1", "p3"], "signatures": {"p1": "x5+", "p3": "x5+"}},
        {"group": "B", "hypothesis": "input:u1", "pots": ["p2", "p4"], "signatures": {"p2": "x5+ U_pot-", "p4": "x5- U_pot+"}},
        {"group": "C", "hypothesis": None, "pots": ["p5"], "signatures": {"p5": "U_pot+"}},
        {"group": "D", "hypothesis": "term:metal_mass", "pots": ["p6"], "signatures": {"p6": "x5+"}},
    ]  # fmt: skip
    assert [g["pots"] for g in group_pots(screens, equivalence=12.0)] == [["p1", "p3", "p4", "p6"], ["p2"], ["p5"]]
    table = line_table(screens, {"p1": "tapping_shortfall"})
    assert len(table) == 14 and set(table.columns) >= {"pot", "channel", "chi2_per_dof", "flagged", "signature"}
    assert table.loc[table.pot == "p1", "hidden"].tolist() == ["tapping_shortfall"] * 2


def _check(flags: dict, members=("pot01", "pot02", "pot03")) -> pd.DataFrame:
    """A hand-made check: pot -> (flagged under the starting model, flagged under the correction), one channel."""
    return pd.DataFrame([
        {"pot": pot, "member": pot in members, "model": model, "channel": "x5", "chi2_per_dof": 30.0 if f else 1.0, "flagged": f}
        for pot, (start, corrected) in flags.items() for model, f in (("start", start), ("corrected", corrected))
    ])  # fmt: skip


def test_a_groups_correction_leaves_its_own_pots_disagreeing_or_explains_another_groups():
    checked = _check({"pot01": (True, False), "pot02": (True, True), "pot06": (True, False), "pot07": (True, True)})
    assert differing_pots(checked, "start") == ["pot01", "pot02", "pot06", "pot07"]
    assert differing_pots(checked, pots=["pot01", "pot02", "pot03"]) == ["pot02"]
    assert explained_pots(checked, ["pot01", "pot02", "pot03"]) == ["pot06"]


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
    meta = group_meta(line, {"group": "A", "hypothesis": "input:u4", "pots": ["pot01", "pot03"]})
    assert meta["accepted"] == ["input:u4"] and "(2 pots)" in meta["hidden"]
    mixed = group_meta(line, {"group": "B", "hypothesis": None, "pots": ["pot00", "pot01"]})
    assert "accepted" not in mixed  # pots hiding different things: nothing to judge the group by
    screens = {"pot00": _screen(x5=None), "pot01": _screen("input:u4", x5=0.4), "pot02": _screen("input:u4", x5=0.3),
               "pot03": _screen("input:u4", x5=0.2)}  # fmt: skip
    groups = group_pots(screens, equivalence=10.0)
    findings = {"A": {"outcome": "found", "named": ["input:u4"], "accepted": ["input:u4"], "flagged_channels": ["x5"],
                      "rounds": [{"correction": {"closed_form": "-0.1"}}]}}  # fmt: skip
    checks = {"A": _check({"pot01": (True, False), "pot02": (True, True), "pot03": (True, False)})}
    page = line_page(line, line_table(screens, line.effects), groups, findings, checks)
    assert "Pots hiding nothing: 2, flagged 1 (pot02)." in page
    assert "tapping_shortfall (pot01, pot03): in group A; A: right; A's correction explains pot01, pot03." in page
    assert "| A | pot01, pot02, pot03 | found | input:u4 | -0.1 | pot02 | none |" in page
    assert "- input:u4 (group A, found): pot01, pot03\n- no group's correction: pot02\n" in page


def test_the_page_says_which_correction_explains_which_pots_and_its_equivalents():
    """A group not identifiable lists its correction with the explanations as good; the flagged pots
    that no correction brings within noise are listed apart."""
    line = Line.from_config({"name": "l", "starting_model": "full", "held_out_fraction": 0.34, "records": {
        "pot01": "a", "pot02": "b", "pot03": "c"}})  # fmt: skip
    screens = {"pot01": _screen("input:u4", x5=0.4), "pot02": _screen("input:u4", x5=0.3), "pot03": _screen(x5=-0.5)}
    groups = [{"group": "A", "hypothesis": "input:u4", "pots": ["pot01", "pot02"]}]
    findings = {"A": {"outcome": "not identifiable", "named": [], "rounds": [
        {"correction": {"hypothesis": "input:u4", "closed_form": "-0.1"}, "equivalent": [{"hypothesis": "term:metal_mass"}]}]}}  # fmt: skip
    checks = {
        "A": _check({"pot01": (True, False), "pot02": (True, False), "pot03": (True, True)}, members=("pot01", "pot02"))
    }
    page = line_page(line, line_table(screens, {}), groups, findings, checks)
    assert (
        "- input:u4, or term:metal_mass (group A, not identifiable): pot01, pot02\n- no group's correction: pot03\n"
        in page
    )


def test_a_pot_another_groups_correction_explains_is_pooled_into_that_group_and_searched_again():
    """Group A's correction brings its own pots and pot06 (group D, which its own group's correction
    leaves disagreeing) within noise: pot06 moves to A, D is gone, A is searched again; pot07, which
    A's correction also explains but its own group E's does too (and E's leaves pot01 disagreeing),
    stays in E.  The page's answer is the second pass's."""
    groups = [
        {"group": "A", "hypothesis": "input:u4", "pots": ["pot01", "pot02"], "signatures": {"pot01": "x5+", "pot02": "x5+"}},
        {"group": "D", "hypothesis": "transfer:ledge_mass->metal_mass", "pots": ["pot06"], "signatures": {"pot06": "x5+"}},
        {"group": "E", "hypothesis": "term:metal_mass", "pots": ["pot07"], "signatures": {"pot07": "x5-"}},
    ]  # fmt: skip
    flagged = {"pot01": (True, False), "pot02": (True, False), "pot06": (True, False), "pot07": (True, False)}
    checks = {
        "A": _check(flagged, members=("pot01", "pot02")),
        "D": _check({**flagged, "pot06": (True, True)}, members=("pot06",)),
        "E": _check({**flagged, "pot01": (True, True)}, members=("pot07",)),  # not A's pots: A and E stay two
    }
    pooled = pool_again(groups, checks)
    assert [(g["group"], g["pots"], g["from"], g["again"]) for g in pooled] == [
        ("A", ["pot01", "pot02", "pot06"], ["A", "D"], True),
        ("E", ["pot07"], ["E"], False),
    ]
    assert pooled[0]["signatures"] == {"pot01": "x5+", "pot02": "x5+", "pot06": "x5+"}
    assert pool_again(groups, {}) == [{**g, "from": [g["group"]], "again": False} for g in groups]
    line = Line.from_config({"name": "l", "starting_model": "full", "held_out_fraction": 0.34, "records": {
        p: p for p in flagged}})  # fmt: skip
    screens = {pot: _screen("input:u4", x5=0.4) for pot in flagged}
    findings = {g: {"outcome": "unexplained", "named": [], "rounds": []} for g in "ADE"}
    again = {"A": {"outcome": "found", "named": ["input:u4"], "rounds": [{"correction": {"closed_form": "-0.1"}}]}}
    again_checks = {"A": _check(flagged, members=("pot01", "pot02", "pot06"))}
    page = line_page(line, line_table(screens, {}), groups, findings, checks, pooled, again, again_checks)
    assert "| A | pot01, pot02, pot06 | A, D | found | input:u4 | -0.1 | none | pot07 |" in page
    assert "- input:u4 (group A, found): pot01, pot02, pot06, pot07\n- no group's correction: none\n" in page
    assert "Pooled again" not in line_page(line, line_table(screens, {}), groups, findings, checks)


def test_two_groups_whose_corrections_each_explain_the_others_pots_are_one_group_searched_again():
    """Groups C (pot04, pot10) and E (pot17) each explained by their own correction, and each correction
    bringing the other group's pots within noise: one group, C with E's pot, searched again (one name
    decided on all three pots); where E's correction does not explain C's pots, E keeps its pot."""
    groups = [
        {"group": "C", "hypothesis": "part:bath_conductivity", "pots": ["pot04", "pot10"], "signatures": {}},
        {"group": "E", "hypothesis": "part:cell_voltage", "pots": ["pot17"], "signatures": {}},
    ]  # fmt: skip
    flagged = {"pot04": (True, False), "pot10": (True, False), "pot17": (True, False)}
    mutual = {"C": _check(flagged, members=("pot04", "pot10")), "E": _check(flagged, members=("pot17",))}
    assert [(g["group"], g["pots"], g["from"], g["again"]) for g in pool_again(groups, mutual)] == [
        ("C", ["pot04", "pot10", "pot17"], ["C", "E"], True)
    ]
    one_way = {**mutual, "E": _check({**flagged, "pot04": (True, True)}, members=("pot17",))}
    assert [(g["group"], g["pots"], g["again"]) for g in pool_again(groups, one_way)] == [
        ("C", ["pot04", "pot10"], False), ("E", ["pot17"], False)
    ]  # fmt: skip


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
    flagged in the metal, above the model (more metal left in the pot).  Checked alone, each agrees
    with the model it was made with and disagrees with the other's."""
    line = Line.from_config({"name": "t", "starting_model": "full", "held_out_fraction": 0.34, "simulated": {
        "pots": 2, "sensors": "pot_line", "groups": [{"case": "tapping_shortfall", "pots": [1]}]}})  # fmt: skip
    model, settings = starting_model(default_config, "full"), settings_from_config(default_config)
    records = {pot: pot_record(default_config, line, pot) for pot in line.pots}
    assert not records["pot00"][["U_pot"]].equals(records["pot01"][["U_pot"]])
    screens = {
        pot: screen_pot(model, r, line.declared_noise(default_config), settings, pot) for pot, r in records.items()
    }
    assert screens["pot00"]["signature"] == "" and screens["pot00"]["best"] == []
    assert screens["pot01"]["signature"].startswith("x5+") and screens["pot01"]["best"][0]["hypothesis"] == "input:u4"
    true, _ = CASES["tapping_shortfall"].models(model)  # the model each pot was made with agrees with it, the other not
    checked = check_pots({"start": model, "true": true}, records, line.declared_noise(default_config), settings)
    assert differing_pots(checked, "start") == ["pot01"] and differing_pots(checked, "true") == ["pot00"]


def test_a_line_of_your_records_screens_each_file_and_simulates_nothing(default_config, tmp_path):
    """``line: records:``: each pot's file (the data contract, one trajectory) is screened as it is;
    the DAG up to the checkpoint has a screen a pot and no simulated pot."""
    line = Line.from_config({"name": "t", "starting_model": "full", "held_out_fraction": 0.34, "simulated": {
        "pots": 2, "sensors": "pot_line", "groups": []}})  # fmt: skip
    for pot in line.pots:
        write_trajectories(pot_record(default_config, line, pot), tmp_path / f"{pot}.parquet", {})
    (tmp_path / "mine.yaml").write_text(
        "output: {results: results/mine, report: results/mine/report}\n"
        "line: {name: mine, records: {pot12: pot00.parquet, pot13: pot01.parquet}, noise: {x6: 1.5, c3: 0.002, x5: 15}}\n"
    )
    result = snakemake(
        tmp_path, "results/mine/line/mine/line.md", "--configfile", "mine.yaml", "--dry-run", check=False
    )
    assert result.returncode == 0, result.stderr[-4000:]
    assert re.search(r"line_screen\s+2\b", result.stdout) and "line_pot" not in result.stdout, result.stdout[-2000:]


def test_a_line_of_historian_exports_imports_each_pot_then_screens_it(tmp_path):
    """``line: historian:``: each pot's export is imported by its own job (its tag map its own or the
    line's) and then screened; a pot without any tag map is named in one line."""
    for name in ("a.csv", "b.csv", "b_lab.csv"):
        (tmp_path / name).write_text("")
    for name in ("tags.yaml", "b_tags.yaml"):
        (tmp_path / name).write_text((REPOSITORY / "examples/pot-line/tags.yaml").read_text())
    pots = "{pot12: {export: a.csv}, pot13: {export: b.csv, tags: b_tags.yaml, lab: b_lab.csv}}"
    (tmp_path / "mine.yaml").write_text(
        "output: {results: results/mine, report: results/mine/report}\n"
        f"line: {{name: mine, historian: {{tags: tags.yaml, pots: {pots}, unlogged_inputs: {{u5: 0.05}}}},"
        " noise: {x6: 1.5, c3: 0.002, x5: 15}}\n"
    )
    result = snakemake(
        tmp_path, "results/mine/line/mine/line.csv", "--configfile", "mine.yaml", "--dry-run", check=False
    )
    assert result.returncode == 0, result.stderr[-4000:]
    assert re.search(r"line_pot_import\s+2\b", result.stdout) and re.search(r"line_screen\s+2\b", result.stdout)
    assert "b_lab.csv" in result.stdout and not re.search(r"line_pot\s+\d", result.stdout), result.stdout[-2000:]
    section = {"name": "l", "historian": {"tags": "t.yaml", "pots": {"p1": {"export": "a.csv"}}}}
    line = Line.from_config(load_config(overrides={"line": section})["line"])
    assert line.pots == ("p1",) and not line.simulated and line.historian["max_gap_s"] == 600
    assert line.historian_files("p1") == {"tags": "t.yaml", "export": "a.csv"}
    with pytest.raises(ConfigError, match=r"^line.historian.pots.p1: no tag map"):
        load_config(overrides={"line": {**section, "historian": {"pots": {"p1": {"export": "a.csv"}}}}})
    (tmp_path / "b.csv").unlink()  # checked before anything is scheduled: the file, then the tag map
    result = snakemake(
        tmp_path, "results/mine/line/mine/line.csv", "--configfile", "mine.yaml", "--dry-run", check=False
    )
    assert (
        result.returncode != 0
        and "invalid data at 'line.historian.pots.pot13.export': b.csv does not exist" in result.stderr
    )
    (tmp_path / "b.csv").write_text("")
    (tmp_path / "b_tags.yaml").write_text("signals: {V: {to: U_pot, unit: parsec}}\n")
    result = snakemake(
        tmp_path, "results/mine/line/mine/line.csv", "--configfile", "mine.yaml", "--dry-run", check=False
    )
    assert result.returncode != 0 and "invalid data at 'line.historian.pots.pot13.tags': b_tags.yaml" in result.stderr


@pytest.mark.integration  # about 40 s: two 4-day pots simulated, exported, imported and screened
def test_two_pots_exported_as_a_historian_writes_them_are_imported_and_screened(tmp_path):
    """examples/pot-line/make_export.py for two pots (one hiding nothing, one fed 92 % of its
    command), each imported by its own job from the example's tag map; each pot one stretch (the
    export's 30 min outage cuts it: the longest kept, the cut in its import report), then screened."""
    from conftest import repository_copy, run_command

    work = repository_copy(tmp_path / "repo")
    for pot, case in (("potA", "no_effect"), ("potB", "alumina_feeder")):
        made = run_command(
            work,
            f"PYTHONPATH=src {sys.executable} examples/pot-line/make_export.py --days 4 --case {case} --folder data/{pot}",
        )
        assert made.returncode == 0, made.stderr
    pots = ", ".join(
        f"{p}: {{export: data/{p}/export.csv, events: data/{p}/events.csv, lab: data/{p}/lab.csv}}"
        for p in ("potA", "potB")
    )
    (work / "hist.yaml").write_text(
        "output: {results: results/hist, report: results/hist/report}\n"
        f"line: {{name: hist, historian: {{tags: examples/pot-line/tags.yaml, timezone: Europe/Oslo, pots: {{{pots}}},"
        " unlogged_inputs: {u5: 0.05}}, noise: {U_pot: 0.005, x6: 1.5, c3: 0.002, x5: 15}}\n"
    )
    ran = snakemake(work, "results/hist/line/hist/line.csv", "--configfile", "hist.yaml", check=False)
    assert ran.returncode == 0, ran.stderr[-4000:]
    root = work / "results/hist/line/hist"
    for pot in ("potA", "potB"):
        assert (root / "pots" / pot / "historian" / "channels.png").exists()
        record = pd.read_parquet(root / "pots" / pot / "record.parquet")
        hours = len(record) * 10 / 3600  # the outage on day 2 cuts 96 h in two: the longer kept
        assert record["trajectory"].nunique() == 1 and 48 < hours < 95, hours
    flagged = pd.read_csv(root / "line.csv").groupby("pot")["flagged"].any()
    assert flagged.to_dict() == {"potA": False, "potB": True}


@pytest.mark.integration
def test_a_small_simulated_line_runs_through_the_workflow(tiny_line_run):
    """Four pots of 60 h, two tapped short: screened, grouped, each group searched and its correction
    checked on its pots, the page written."""
    root = tiny_line_run / "results/tinyline/line/tiny"
    groups = json.loads((root / "groups.json").read_text())
    assert all(set(g["pots"]) <= {"pot01", "pot02"} for g in groups)  # the pots hiding nothing agree
    page = (root / "line.md").read_text()
    assert "Pots hiding nothing: 2, flagged 0." in page and (root / "line.png").exists()
    for g in groups:  # each group's correction checked on its pots alone, under both models
        checked = pd.read_csv(root / "groups" / g["group"] / "pots.csv")
        assert set(checked["pot"]) == set(g["pots"]) and set(checked["model"]) == {"start", "corrected"}
