"""The discovery benchmark: drawn effects, their truth and signal, the scorer, the seed ranges."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest
from conftest import REPOSITORY, snakemake

from costa.benchmark.score import (
    peer_rates,
    projected_hours,
    rates,
    recall_by_signal,
    strong_by_kind,
    strong_by_kind_markdown,
    wilson,
)
from costa.benchmark.signal import signal
from costa.benchmark.truth_listed import listed_rates, recommending_rounds, truth_listed_table
from costa.compiled import CompiledModel
from costa.config import ConfigError, check_consistency
from costa.discover.cases.drawn import (
    FAMILIES,
    NULL_SHARE,
    OFFSET_SHARE,
    SPLITS,
    DrawnEffect,
    draw_effect,
    drawn_case,
    effect_case,
    equivalent_names,
    split_cases,
)
from costa.discover.cases.unshipped import find_case
from costa.discover.rates import LISTED, PUBLISHED, how_often_right, truth_listed
from costa.discover.summary import judged
from costa.integrate import rk4_step
from costa.physics import operating_points, true_model


def test_the_seed_ranges_never_meet_and_a_split_draws_inside_its_own():
    assert not set(SPLITS["dev"]) & set(SPLITS["test"])
    for split, seeds in SPLITS.items():
        assert all(int(name.removeprefix("drawn")) in seeds for name in split_cases(split, 50))
    with pytest.raises(ValueError, match="seeds hold"):
        split_cases("dev", len(SPLITS["dev"]) + 1)


def test_a_drawn_case_is_a_function_of_its_seed_and_found_by_name():
    assert draw_effect(100_007) == draw_effect(100_007) != draw_effect(100_008)
    assert find_case("drawn100007") is drawn_case("drawn100007")
    assert find_case("drawn100007").accepted[0] == draw_effect(100_007).key


def test_the_draws_cover_every_kind_and_family_with_the_stated_share_of_nulls():
    effects = [draw_effect(seed) for seed in range(2000)]
    nulls = sum(e.kind == "none" for e in effects)
    assert abs(nulls / len(effects) - NULL_SHARE) < 0.03  # 2000 draws: the share's std is 0.008
    drawn = [e for e in effects if e.kind != "none"]
    assert {e.kind for e in drawn} == {"part", "term", "transfer", "property", "input"}
    assert {e.family for e in drawn} == {family for family, _, _ in FAMILIES}
    sizes = np.abs([e.size for e in drawn])
    assert 0.001 <= sizes.min() and sizes.max() <= 0.1 and np.median(sizes) == pytest.approx(0.01, rel=0.2)
    offsets = [e for e in drawn if e.offset]
    assert {e.target for e in offsets} == {"u2", "u5"} and all(e.kind == "input" for e in offsets)
    read_off = [e for e in drawn if e.kind == "input" and e.target in ("u2", "u5")]
    assert abs(len(offsets) / len(read_off) - OFFSET_SHARE) < 0.15  # about 90 such effects in 2000


def test_an_offset_adds_to_the_logged_input_and_a_gain_multiplies_it():
    """u2 read 0.5 % x 140 kA too low (a constant offset): 700 A more reach the cell at every current,
    where a gain of the same size adds 0.5 % of the current; the right name is the input's either way."""
    x, u = operating_points(np.random.default_rng(6), 32)
    full = true_model()
    offset = DrawnEffect(seed=0, kind="input", target="u2", family="constant", variables=(), size=0.005,
                         noise=0.01, offset=True)  # fmt: skip
    gain = replace(offset, offset=False)
    np.testing.assert_allclose(offset.true_model(full).delivered_inputs(x, u)[:, 1] - u[:, 1], 700.0, rtol=1e-9)
    np.testing.assert_allclose(gain.true_model(full).delivered_inputs(x, u)[:, 1], 1.005 * u[:, 1], rtol=1e-12)
    assert effect_case(offset).accepted == effect_case(gain).accepted == ("input:u2",)
    assert "+ 0.005 x 140000 A" in offset.describe() and effect_case(offset).kind == "drawn: input offset (constant)"
    model = offset.true_model(full)  # the compiled step traces the offset's division by the input
    compiled = CompiledModel(model, 10.0, derivatives=False).step(x, u)
    np.testing.assert_allclose(compiled, rk4_step(model.rhs, x, u, 10.0), rtol=1e-12)


def test_every_family_stays_within_its_bound_and_compiles_to_numpys_step():
    """|f| <= 2 over the held range, and the compiled step (which traces the family) equals numpy's."""
    x, u = operating_points(np.random.default_rng(4), 64)
    full = true_model()
    for family, count, _ in FAMILIES:
        effect = DrawnEffect(seed=1, kind="property", target="bath_heat_capacity", family=family,
                             variables=("x6", "c3")[:count], size=0.05, noise=0.01)  # fmt: skip
        extreme = x.copy()
        extreme[:, 5] = np.linspace(900, 1050, len(x))  # z(x6) far beyond [-2, 2]
        from costa.physics import CellVariables

        assert np.abs(effect.shape(CellVariables(extreme, u))).max() <= 2.0 + 1e-12, family
        model = effect.true_model(full)
        compiled = CompiledModel(model, 10.0, derivatives=False).step(x, u)
        np.testing.assert_allclose(compiled, rk4_step(model.rhs, x, u, 10.0), rtol=1e-12, err_msg=family)


def test_the_names_that_are_right_are_the_hypotheses_the_data_cannot_tell_apart():
    """A flow out of a part that enters one balance only is that balance's missing flow (as the shipped
    top heat loss accepts the electric power); an input's gain is not a flow proportional to it."""
    full = true_model()

    def names(kind, target):
        effect = DrawnEffect(seed=0, kind=kind, target=target, family="constant", variables=(), size=0.01, noise=0.01)
        return set(equivalent_names(effect, full))

    assert {"term:bath_energy", "part:electric_power", "part:bath_ledge_heat"} <= names("term", "bath_energy")
    assert names("term", "alumina_mass") == {"term:alumina_mass", "part:alumina_consumption"}
    assert names("input", "u4") == {"input:u4"} and names("input", "u1") == {"input:u1"}
    assert "property:wall_conductivity" not in names("property", "ledge_conductivity")


def test_the_signal_is_zero_without_an_effect_and_grows_with_its_size(smoke_config):
    effect = DrawnEffect(seed=100_003, kind="term", target="alf3_mass", family="linear", variables=("x6",),
                         size=0.01, noise=0.01)  # fmt: skip
    shown = {size: signal(smoke_config, effect_case(replace(effect, size=size)), "full") for size in (0.0, 0.01, 0.04)}
    assert shown[0.0]["signal"] == 0.0 and shown[0.01]["samples"] > 0
    assert 0 < shown[0.01]["signal"] < shown[0.04]["signal"]
    assert shown[0.04]["signal"] == pytest.approx(4 * shown[0.01]["signal"], rel=0.05)  # small: about linear
    null = effect_case(replace(effect, kind="none", target="", size=0.0))
    assert signal(smoke_config, null, "full")["signal"] == 0.0


def _findings(accepted, named=(), outcome="no effect", flagged=(), listed=(), not_fitted=()):
    rounds = [{"correction": {"hypothesis": listed[0]} if listed else None,
               "equivalent": [{"hypothesis": h} for h in listed[1:]],
               "not_fitted": [{"hypothesis": h} for h in not_fitted]}]  # fmt: skip
    return {"accepted": list(accepted), "named": list(named), "outcome": outcome, "flagged_channels": list(flagged),
            "rounds": rounds}  # fmt: skip


@pytest.mark.parametrize(
    ("findings", "verdict"),
    [
        (_findings(["term:x", "part:y"], ["part:y"], "found", ["x2"]), "right"),
        (_findings(["term:x"], ["term:z", "term:x"], "found", ["x2"]), "wrong"),
        (_findings(["term:x"], [], "not identifiable", ["x2"], ["term:z", "term:x"]), "not identifiable, truth listed"),
        (_findings(["term:x"], [], "not identifiable", ["x2"], ["term:z"]), "not identifiable, truth not listed"),
        (
            _findings(["term:x"], [], "not identifiable", ["x2"], ["term:z"], ["term:x"]),
            "not identifiable, truth listed",
        ),
        (_findings(["term:x"], [], "unexplained", ["x2"]), "unexplained"),
        (_findings(["term:x"]), "missed"),
        (_findings([]), "quiet"),
        (_findings([], [], "unexplained", ["x2"]), "false alarm"),
        (_findings([], ["term:z"], "found", ["x2"]), "false name"),
    ],
)
def test_each_answer_is_judged_against_the_truth(findings, verdict):
    assert judged(findings) == verdict


def test_wilson_intervals_have_their_known_values():
    assert wilson(0, 10) == pytest.approx((0.0, 0.2775), abs=1e-4)
    assert wilson(5, 10) == pytest.approx((0.2366, 0.7634), abs=1e-4)
    assert all(np.isnan(wilson(0, 0)))


def test_rates_count_names_right_over_names_given_and_over_effects():
    verdicts = ["right"] * 6 + ["wrong"] * 2 + ["missed"] * 2 + ["quiet"] * 3 + ["false name"]
    kinds = ["term"] * 10 + ["none"] * 4
    table = pd.DataFrame({"sensors": "full", "verdict": verdicts, "kind": kinds, "seconds": 1.0,
                          "signal": [1.0, 5, 20, 50, 200, 2000, 1, 5, 1, 2, 0, 0, 0, 0]})  # fmt: skip
    row = rates(table).iloc[0]
    assert (row.effects, row.nulls, row.right, row.wrong, row["false name"]) == (10, 4, 6, 2, 1)
    assert row.precision == pytest.approx(6 / 9) and row.recall == pytest.approx(6 / 10)
    assert row.false_alarm_rate == pytest.approx(1 / 4)
    assert (row.precision_low, row.precision_high) == pytest.approx(wilson(6, 9))
    assert (row.strong_effects, row.strong_right) == (2, 2)  # signal >= 100 noise units: 200 and 2000
    curve = recall_by_signal(table, [0, 3, 10, 100, np.inf])
    assert curve.effects.tolist() == [4, 2, 2, 2] and curve.right.tolist() == [1, 1, 2, 2]


def test_strong_effects_are_counted_by_kind_and_by_how_each_was_not_named():
    """Only effects of signal >= 100 count; the two kinds of not identifiable are one column; nulls are left out."""
    table = pd.DataFrame({
        "sensors": "partial",
        "kind": ["term", "term", "term", "part", "part", "part", "part", "none"],
        "verdict": ["right", "missed", "right", "wrong", "not identifiable, truth listed",
                    "not identifiable, truth not listed", "unexplained", "false alarm"],
        "signal": [500.0, 100, 99, 1e4, np.inf, 300, 200, 0],
    })  # fmt: skip
    by_kind = strong_by_kind(table).set_index("kind")
    assert by_kind.effects.to_dict() == {"term": 2, "part": 4}
    assert by_kind.loc["term", ["right", "missed"]].tolist() == [1, 1]
    part = by_kind.loc["part"]
    assert part[["right", "wrong", "not identifiable", "unexplained", "missed"]].tolist() == [0, 1, 2, 1, 0]
    assert by_kind.loc["term", "recall"] == 0.5
    assert part[["recall_low", "recall_high"]].tolist() == pytest.approx(wilson(0, 4))
    assert "| partial | part | 4 | 0 | 1 | 2 | 1 | 0 | 0% [0%, 49%] |" in strong_by_kind_markdown(strong_by_kind(table))


def test_a_findings_page_quotes_the_published_test_rates_of_records_sampled_alike_and_nothing_else(tmp_path):
    """The plant set's for a record sampled as a plant's, in words with their intervals; a dev run's
    rates are never quoted, and without a published file a page says nothing."""
    verdicts = ["right"] * 3 + ["wrong"] + ["missed"] * 2
    table = pd.DataFrame({"sensors": ["plant"] * 6 + ["pot_line"] * 6, "verdict": verdicts * 2, "kind": "term",
                          "seconds": 1.0, "signal": [500.0, 500, 50, 500, 500, 5] * 2})  # fmt: skip
    published = tmp_path / "rates.csv"
    rates(table).assign(split=["test", "dev"], size="quick").to_csv(published, index=False)
    (sentence,) = how_often_right("plant", published)
    low, high = wilson(3, 4)
    assert sentence.startswith("on the benchmark's plant records (6 drawn cases of its test seeds, quick size)")
    assert f"a name was right in 3 of 4 (75%, 95 % interval {low:.0%}-{high:.0%})" in sentence
    assert sentence.endswith("effects above 100 noise units were named right in 2 of 4 (50%, 95 % interval 15%-85%)")
    assert how_often_right("pot_line", published) == []  # a dev run's
    assert how_often_right("full", published) == [] and how_often_right("full", tmp_path / "none.csv") == []


def _recommending(case: str, accepted: list[str], verdicts_and_explanations) -> dict:
    """A run's findings as the truth-listed count reads them: each round's verdict and its first recommendation's
    explanations (a round without any recommended nothing)."""
    rounds = [
        {"round": i + 1, "verdict": verdict, "measure_next": [{"explanations": keys}] if keys else []}
        for i, (verdict, keys) in enumerate(verdicts_and_explanations)
    ]
    return {"case": case, "accepted": accepted, "rounds": rounds}


def test_the_truth_is_counted_among_a_recommendations_explanations_per_set_and_outcome(tmp_path):
    """Three unexplained rounds, one holding an accepted name, and a null case's flagged round (whose truth,
    nothing, no explanation holds); two not identifiable, both holding it; a round without a recommendation
    is not counted.  The shares and their Wilson intervals are what a findings page reads back."""
    runs = [
        _recommending("drawn1/plant", ["part:a", "part:b"], [("unexplained: ...", ["part:c", "part:b"])]),
        _recommending(
            "drawn2/plant", ["part:a"], [("unexplained: ...", ["part:c"]), ("not identifiable: x", ["part:a"])]
        ),
        _recommending("drawn3/plant", [], [("unexplained: ...", ["part:a"])]),
        _recommending("drawn4/plant", ["term:x"], [("not identifiable: y", ["term:x", "part:c"]), ("quiet", [])]),
    ]
    rows = pd.DataFrame([row for found in runs for row in recommending_rounds(found, "plant")])
    assert len(rows) == 5 and rows.listed.tolist() == [True, False, True, False, True]
    table = listed_rates(rows).set_index("outcome")
    assert table.loc["unexplained", ["rounds", "listed"]].tolist() == [3, 1]
    assert table.loc["not identifiable", ["rounds", "listed", "share"]].tolist() == [2, 2, 1.0]
    assert table.loc["unexplained", ["share_low", "share_high"]].tolist() == pytest.approx(wilson(1, 3))
    paths = [tmp_path / f"run{i}.json" for i in range(len(runs))]
    for path, found in zip(paths, runs, strict=True):
        path.write_text(json.dumps(found))
    pd.testing.assert_frame_equal(truth_listed_table(paths, ["plant"] * len(runs)), listed_rates(rows))
    published = tmp_path / "truth_listed.csv"
    listed_rates(rows).assign(split="dev", size="quick").to_csv(published, index=False)
    row = truth_listed("plant", "unexplained", published)
    assert (row["rounds"], row["listed"], row["split"]) == (3, 1, "dev") and isinstance(row["rounds"], int)
    assert truth_listed("partial", "unexplained", published) is None
    assert truth_listed("plant", "unexplained", tmp_path / "none.csv") is None


def test_the_published_truth_listed_shares_are_a_dev_run():
    """The shares that calibrate a recommendation's chance of a right name (costa/discover/truth_listed.csv)
    come from dev seeds, so the closed loop on the test seeds judges them; each a count of rounds."""
    published = pd.read_csv(LISTED)
    assert (published.split == "dev").all() and (published["size"] == "calibration").all()
    assert set(published.outcome) <= {"unexplained", "not identifiable"}
    assert (published.listed <= published.rounds).all() and (published.rounds > 0).all()
    assert np.allclose(published.share, published.listed / published.rounds)


def test_a_benchmark_size_naming_an_unknown_sensor_set_is_refused(default_config):
    config = {
        **default_config,
        "benchmark": {**default_config["benchmark"], "sizes": {"quick": {"sensors": {"lab": 3}}}},
    }
    with pytest.raises(ConfigError, match=r"benchmark.sizes.quick.sensors \['lab'\]"):
        check_consistency(config)


def test_the_peers_are_scored_by_the_equation_they_change_most():
    rows = pd.DataFrame({
        "method": ["PySINDy"] * 4, "true_equations": ["x3", "x6 x7", "x2", "none"],
        "most_changed": ["x3", "x7", "x6", "x1"], "equations_changed": ["x3", "x7 x1", "x6", "x1"],
        "spurious_terms": [0, 1, 2, 1], "seconds": [10.0, 20.0, 30.0, 40.0],
    })  # fmt: skip
    row = peer_rates(rows).iloc[0]
    assert (row.effects, row.most_changed_right, row.nulls, row.nulls_changed) == (3, pytest.approx(2 / 3), 1, 1)
    assert row.spurious_terms_a_case == 1.0 and row.median_seconds == 25.0


@pytest.mark.integration
def test_the_benchmark_runs_end_to_end_at_the_smoke_sizes(tmp_path):
    """Three drawn cases of the dev seeds through the full-state route and one through the peers: one row each,
    judged, with a finite signal; the rates, the curve, the figure and the page."""
    tiny = tmp_path / "tiny_benchmark.yaml"
    tiny.write_text("benchmark: {split: dev, size: tiny, sizes: {tiny: {sensors: {full: 3}, peers: 1}}}\n")
    smoke = str(REPOSITORY / "config" / "smoke.yaml")
    snakemake(tmp_path, "results/smoke/benchmark/summary.csv", "--configfile", smoke, str(tiny))
    results = tmp_path / "results/smoke/benchmark"
    cases = pd.read_csv(results / "summary.csv")
    assert cases.case.tolist() == ["drawn0", "drawn1", "drawn2"] and (cases.sensors == "full").all()
    assert cases.verdict.isin(["right", "wrong", "unexplained", "missed", "quiet", "false alarm", "false name"]).all()
    assert (cases.signal >= 0).all() and (cases.seconds > 0).all()
    assert (cases.signal > 0).tolist() == (cases.kind != "none").tolist()
    table = pd.read_csv(results / "rates.csv")
    assert (
        table.cases.tolist() == [3]
        and table[["right", "wrong", "unexplained", "missed"]].sum(axis=1).item() == 3 - table.nulls.item()
    )
    peers = pd.read_csv(results / "peers.csv")
    assert set(peers.method) == {"this workflow", "PySINDy", "UDE (CoSTA + PySINDy)"}
    page = (results / "benchmark.md").read_text()
    assert "| full | 3 (" in page and "## Against its peers" in page and "by kind" in page
    assert set(pd.read_csv(results / "strong_by_kind.csv").columns) >= {"kind", "effects", "right", "missed", "recall"}
    # full-state rounds recommend no measurement: the count has its columns and no rows
    assert pd.read_csv(results / "truth_listed.csv").columns.tolist()[:4] == ["sensors", "outcome", "rounds", "listed"]
    assert (results / "recall_by_signal.png").stat().st_size > 10_000


def test_a_size_is_projected_from_the_job_seconds_a_case():
    table = pd.DataFrame({"sensors": ["full", "plant"], "total_seconds": [500.0, 300.0], "cases": [10, 2]})
    page = projected_hours(table, {"a": {"full": 72}, "b": {"full": 72, "plant": 24}, "c": {"lab": 1}}, (2, 16, 10_000))
    # a: 72 x 50 s = 1 job hour; 2 cores 30 min, 16 cores 3.75 min, and never below one case's 50 s
    assert "| a | 72 | 1.0 | 30 min | 4 min | 1 min |" in page
    assert "| b | 96 | 2.0 | 1.0 h |" in page and "| c |" not in page  # 72 x 50 + 24 x 150 s


def test_the_published_rates_are_a_test_run_of_every_sensor_set():
    """The rates a findings page quotes (costa/discover/benchmark_rates.csv) come from a test run of
    the five sets, with the counts their rates are made of."""
    published = pd.read_csv(PUBLISHED)
    assert published.sensors.tolist() == ["full", "partial", "plant", "pot_line", "regimes"]
    assert (published.split == "test").all()
    named = published.right + published.wrong + published["false name"]
    assert np.allclose(published.precision[named > 0], (published.right / named)[named > 0])
    assert (published.strong_right <= published.strong_effects).all() and (
        published.strong_effects <= published.effects
    ).all()


def test_the_discovery_guides_first_table_is_the_published_rates_page():
    """docs/discovery.md's table of how often a name is right is the page the workflow writes from the
    published rates, row for row: a rerun that changes the rates changes the guide, or this fails."""
    from costa.benchmark.score import rates_markdown

    published = pd.read_csv(PUBLISHED)
    page = rates_markdown(published, split=published["split"].iloc[0], size=published["size"].iloc[0])
    rows = [line for line in page.splitlines() if line.startswith("| ") and not line.startswith("| sensors")]
    guide = (REPOSITORY / "docs/discovery.md").read_text()
    assert [row for row in rows if row not in guide] == []
    assert guide.index(rows[0]) < guide.index("## How it works")
