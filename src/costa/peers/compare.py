"""One case through this workflow's discovery and its two peers, on the same data, scored alike."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from .. import seeds
from ..data import arrays
from ..discover.cases.truth import TRUTHS, Truth, changed_equations
from ..discover.cases.unshipped import find_case
from ..discover.full_state.gap import gap_tables
from ..discover.pipeline import starting_model
from ..discover.reference import train_costa
from ..metrics import EvaluationSettings, state_scale
from ..physics import model_from_config
from .methods import PeerResult, PeerSettings, pysindy_peer, ude_peer
from .score import ours_answer, peer_answer, score

__all__ = ["METHODS", "compare_case"]

#: the compared methods, in table order
METHODS = ("this workflow", "PySINDy", "UDE (CoSTA + PySINDy)")


def _details(result: PeerResult) -> dict[str, Any]:
    return {
        "grid": result.grid.to_dict(orient="records"),
        "terms": result.fit.terms(),
        "corrected_model": result.corrected.describe(),
        "seconds": round(result.seconds, 1),
    }


def compare_case(
    config: Mapping, name: str, train: pd.DataFrame, held_out: pd.DataFrame, found: Mapping[str, Any]
) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The table rows (one per method) and the peers' details (grids, terms, inclusion) of one case.

    ``found`` is our discovery's findings.json on the same data; its noise floor serves every method.
    """
    case = find_case(name)
    truth = TRUTHS.get(name, Truth(None, None))
    full = model_from_config(config["physics"])[0]
    true, _ = case.models(full)
    start = starting_model(config, case.starting)
    x, u = arrays(train)
    xh, uh = arrays(held_out)
    dt = float(np.diff(train["time_s"].to_numpy()[:2])[0])
    evaluation = EvaluationSettings.from_config(config["evaluation"])
    scale = state_scale(x)
    seed = int(seeds.stream(config["seed"], 0, f"peers/{name}/bagging").generate_state(1)[0])
    settings = PeerSettings.from_config(config["peers"], seed)
    peers = {
        "PySINDy": pysindy_peer(start, x, u, dt, scale, evaluation, settings),
        "UDE (CoSTA + PySINDy)": ude_peer(
            lambda data: train_costa(config, data, start, name), start, x, u, dt, scale, evaluation, settings
        ),
    }
    models = {"starting model": start, **{method: result.corrected for method, result in peers.items()}}
    gaps, _ = gap_tables(models, xh, uh, dt, scale, evaluation)
    before = gaps[gaps["model"] == "starting model"]
    floor = found["gap"]["noise_floor"]["long"]
    true_equations = changed_equations(true, start, xh, uh)
    answers = {"this workflow": (ours_answer(found, start), pd.DataFrame(found["gap"]["errors"]))}
    for method, result in peers.items():
        after = gaps[gaps["model"] == method].assign(model="corrected model")
        answers[method] = (peer_answer(result.fit, result.corrected, result.seconds), pd.concat([before, after]))
    rows = [
        score(name, method, answer, truth, true_equations, start, xh, uh, gap, floor)
        for method, (answer, gap) in answers.items()
    ]
    details = {
        "case": name,
        "hidden": case.hidden,
        "true_equations": list(true_equations),
        "settings": {k: v for k, v in config["peers"].items() if k != "cases"},
        **{method: _details(result) for method, result in peers.items()},
    }
    return pd.DataFrame(rows), details
