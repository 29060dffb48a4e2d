"""One pot screened with the starting model: its channel tests and, where one disagrees, which
hypotheses would explain it: the first, cheap part of discovery.

The pot's record is read as discovery reads it (:func:`costa.discover.sparse.pipeline.observations`),
its first state searched where the record does not place it, and the first round's screen run on
it (:func:`costa.discover.sparse.filter.search.screen_round`): each measured channel's innovations
tested for size, bias and whiteness, and where one disagrees every hypothesis' free delta scored
by the likelihood it gains, the best of each physics kept.  A pot whose channels all agree needs
nothing more; the others are grouped by what explains them best (:mod:`.groups`).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from ..discover.core.settings import DiscoverySettings
from ..discover.sparse.filter.search import screen_round
from ..discover.sparse.pipeline import observations
from ..physics import CellModel

__all__ = ["screen_pot", "signature"]


def screen_pot(
    model: CellModel, record: pd.DataFrame, declared_noise: Mapping[str, float], settings: DiscoverySettings,
    source: str,
) -> dict[str, Any]:  # fmt: skip
    """The screen of one pot's ``record`` under ``model``: per channel its samples, chi2/dof, z, bias (in
    noise stds) and its z, whiteness z and whether it disagrees (``flagged``); where one does, every
    hypothesis that explains some of it (``best``, best first), one of each physics, with its log-likelihood gain."""
    started = time.perf_counter()
    obs = observations(record, declared_noise, source).with_start(model)
    screen = screen_round(model, obs, settings, np.random.default_rng(0), ())
    tests = screen.tests
    channels = [
        {
            "channel": t.channel, "samples": t.samples, "chi2_per_dof": round(t.chi2_per_dof, 4), "z": round(t.z, 2),
            "bias": round(t.bias, 4), "bias_z": round(t.bias_z, 2), "whiteness_z": round(t.whiteness_z, 2),
            "flagged": t.flagged,
        }
        for t in tests
    ]  # fmt: skip
    hours = obs.y.shape[1] * obs.dt / 3600
    scored = sorted([*screen.candidates, *screen.others], key=lambda c: -c.log_likelihood_gain)
    best = [{"hypothesis": c.hypothesis.key, "gain": round(float(c.log_likelihood_gain), 1)} for c in scored]
    return {
        "hours": round(float(hours), 2),
        "channels": channels,
        "flagged": [c["channel"] for c in channels if c["flagged"]],
        "signature": signature(channels),
        "best": best,
        "seconds": round(time.perf_counter() - started, 2),
    }


def signature(channels: list[Mapping[str, Any]]) -> str:
    """How a pot disagrees, in one word a channel: each flagged channel with the sign of its innovations'
    bias (``x6+``: the data above the model's prediction), in the record's channel order; "" where none is."""
    return " ".join(f"{c['channel']}{'+' if np.sign(c['bias']) >= 0 else '-'}" for c in channels if c["flagged"])
