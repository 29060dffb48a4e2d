"""Discovery from partial, sparse measurements: named from the channels a cell has, or honestly not."""

from __future__ import annotations

import copy
import json
from dataclasses import replace

import numpy as np
import pytest

from costa.config import load_config
from costa.discover.findings import findings, findings_markdown
from costa.discover.hypotheses import candidate_hypotheses
from costa.discover.partial import Observations, channel_noise, score_hypotheses
from costa.discover.partial_pipeline import PartialResult
from costa.discover.partial_search import separating_channel
from costa.discover.pipeline import case_tables, run_discovery, starting_model
from costa.observe import observe
from costa.physics import true_model
from costa.plots import plot_discovery

REDUCED = {"trajectories": 6, "held_out_trajectories": 3, "bootstrap": 100}


def _reduced(default_config, steps: int = 1000) -> dict:
    config = copy.deepcopy(default_config)
    config["simulation"]["steps"] = steps
    config["evaluation"]["windows"] = {"short": [0, 30], "medium": [30, steps // 2], "long": [steps // 2, steps]}
    config["evaluation"]["horizons"] = {"short": 30, "medium": steps // 2, "long": steps}
    config["discovery"].update(REDUCED)
    return config


def test_channel_noise_is_estimated_where_dense_and_declared_where_sparse():
    rng = np.random.default_rng(0)
    smooth = np.cumsum(rng.normal(size=(3, 2000)) * 0.01, axis=1)
    y = np.stack(
        [smooth + rng.normal(size=smooth.shape) * 0.2, np.where(np.arange(2000) % 360 == 0, smooth, np.nan)], -1
    )
    noise = channel_noise(y, ("x6", "c3"), {"c3": 0.002})
    assert noise[0] == pytest.approx(0.2, rel=0.05) and noise[1] == 0.002
    with pytest.raises(ValueError, match="channel 'c3' is not sampled at every step.*declare it in discovery.user_data"):
        channel_noise(y, ("x6", "c3"), {})


def test_paper_liquidus_is_named_from_partial_measurements(default_config):
    """No ledge, no masses measured: bath and wall temperature, metal, cell voltage and composition.
    The ablated PBM's missing liquidus law is named, its closed form recovered, the gap closed."""
    config = _reduced(default_config)
    train, held_out = case_tables(config, "paper_liquidus", "partial")
    assert {"x1", "x2", "x7"}.isdisjoint(train.columns) and {"U_cell", "c2", "c3"} <= set(train.columns)
    start = starting_model(config, "ablated")
    result = run_discovery(config, train, held_out, start, "paper_liquidus/partial", "test")
    assert isinstance(result, PartialResult)
    first = result.rounds[0]
    assert {"x6", "U_cell"} <= set(first.flagged) and "x5" not in first.flagged
    assert first.named is not None and first.named.key == "part:liquidus_temperature"
    names = [f.name for f in first.chosen.features]
    assert {"(c2 - 0.03)", "(c3 - 0.11)"} <= {n.replace("own*", "") for n in names}
    for lo, hi in first.chosen.intervals(0.99):  # every kept term's reported interval excludes zero
        assert lo > 0 or hi < 0
    assert not result.rounds[-1].flagged
    found = findings(
        result, "paper_liquidus/partial", start, {"data": "test", "accepted": ["part:liquidus_temperature"]}
    )
    assert found["outcome"] == "found" and found["measurements"] == "partial"
    json.dumps(found)  # plain JSON types throughout
    assert found["gap"]["shrink_above_noise_floor"]["long"] > 0.8
    text = findings_markdown(found)
    assert "| channel | meaning | samples |" in text and "**Named**: `part:liquidus_temperature`" in text
    figure = plot_discovery(found, result.gap)
    assert [t.get_text() for t in figure.axes[0].get_xticklabels()] == list(result.channels)


def test_no_effect_under_partial_measurements_names_nothing(default_config):
    config = _reduced(default_config, steps=1000)
    train, held_out = case_tables(config, "no_effect", "partial")
    start = starting_model(config, "full")
    result = run_discovery(config, train, held_out, start, "no_effect/partial", "test")
    assert not result.rounds[0].flagged and result.rounds[0].chosen is None
    assert result.corrected is start


def test_one_sensor_cannot_tell_alumina_lost_from_cryolite_gained():
    """A missing alumina flow seen only through the alumina fraction c2: a flow out of the alumina
    balance and a flow into the cryolite balance both lower c2; only the masses, or c3, would tell
    them apart.  Their scores are close, and the channel that would separate them is an unmeasured one."""
    model = true_model()
    rng = np.random.default_rng(4)
    from costa.simulate import SimulationSettings, simulate_set

    settings = SimulationSettings.from_config(load_config()["simulation"])
    hidden = next(h for h in candidate_hypotheses(model) if h.key == "term:alumina_mass")
    truth = hidden.corrected(model, hidden.features()[:1], [-0.002])
    trajectories, _ = simulate_set(truth, replace(settings, steps=600), 3, 5, 0, "equivalence")
    c2 = observe(truth, trajectories.x, trajectories.u, ["c2"])
    y = c2 + rng.normal(size=c2.shape) * 2e-5
    obs = Observations(y, trajectories.u, ("c2",), np.array([2e-5]), 10.0)
    keys = ["term:alumina_mass", "term:cryolite_mass"]
    scores, _ = score_hypotheses(model, [h for h in candidate_hypotheses(model) if h.key in keys], obs, 64)
    gains = {s.hypothesis.key: s.log_likelihood_gain for s in scores}
    assert gains["term:alumina_mass"] > 50 and gains["term:cryolite_mass"] > 0.9 * gains["term:alumina_mass"]
    histories = [trajectories.x, trajectories.x * np.array([1, 1, 1, 1.02, 1, 1, 1, 1])]
    assert separating_channel(histories, trajectories.u, model, ("c2",)) in ("x4", "c3", "x3", "x2")
