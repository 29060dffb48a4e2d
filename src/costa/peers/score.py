"""One row per case and method, scored against the case's truth alike for every method.

Columns (``COLUMNS``): the effect it names ("—" for a method that cannot name one),
the equations it changes (those whose rate differs from the starting model's), the one it
changes most (relative to that rate's spread) and those the effect changes, whether the effect's variables appear in its terms, the
relative error of each true coefficient that has a counterpart in the method's own
representation, the spurious terms (in an equation the effect leaves alone, or
reading a variable the effect and its flow forms do not), the long-window error
before and after on the held-out trajectories beside the noise floor, the share of
the gap above the floor it closes, blow-ups and seconds.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from ..discover.cases.truth import Truth, changed_equations, correction_variables
from ..discover.findings import corrected_model
from ..physics import BALANCES, CellModel
from ..variables import STATES
from .sparse import SparseFit

__all__ = ["COLUMNS", "DASH", "Answer", "ours_answer", "peer_answer", "score"]

DASH = "—"
COLUMNS = [
    "case", "method", "named", "equations_changed", "most_changed", "true_equations", "right_variables", "coefficient_errors",
    "max_coefficient_error", "spurious_terms", "terms", "error_before", "error_after", "noise_floor",
    "gap_closed_above_floor", "blowups", "rollouts", "seconds", "correction",
]  # fmt: skip
_STATE_OF = {balance: state for balance, (state, _) in BALANCES.items()}


class Answer(dict):
    """What a method says: ``named`` (list of effect keys or None), ``model`` (corrected),
    ``terms`` [(representation, equations, term, value)], ``correction`` text, ``seconds``."""


def ours_answer(found: Mapping[str, Any], start: CellModel) -> Answer:
    """Our discovery's answer, read from its findings.json; the corrected model rebuilt from the
    applied closed forms round by round (hypothesis, terms, coefficients), named or not identifiable."""
    terms, texts = [], []
    for r in found["rounds"]:
        named = r["correction"]  # applied, whether or not the data could name it
        if named:
            terms += [(named["hypothesis"], None, c["term"], c["value"]) for c in named["coefficients"]]
            texts.append(f"{named['hypothesis']}: {named['closed_form']}")
    names = [r["named"]["hypothesis"] for r in found["rounds"] if r["named"]]
    return Answer(named=names, model=corrected_model(found, start), terms=terms, correction=" | ".join(texts),
                  seconds=found["discovery_seconds"])  # fmt: skip


def peer_answer(fit: SparseFit, corrected: CellModel, seconds: float) -> Answer:
    """A peer's answer: one flow per changed balance, no name."""
    state_to_balance = {state: balance for balance, state in _STATE_OF.items()}
    terms = []
    for state, found in fit.terms().items():
        balance = state_to_balance[state]
        terms += [(f"term:{balance}", (state,), t["term"], t["value"]) for t in found]
    texts = [f"{next(iter(term.targets))}: {term.formula}" for term in corrected.terms]
    return Answer(named=None, model=corrected, terms=terms, correction=" | ".join(texts), seconds=seconds)


def _coefficients(answer: Answer, truth: Truth) -> tuple[str, float]:
    """'term: relative error' for each true coefficient whose representation the method uses."""
    found: dict[str, dict[str, float]] = {}
    for representation, _, term, value in answer["terms"]:
        found.setdefault(representation, {}).setdefault(term, 0.0)
        found[representation][term] += value  # a later round may refine a term named before
    parts, worst = [], np.nan
    for representation, true in truth.coefficients.items():
        if representation not in found:
            continue
        for term, value in true.items():
            if term in found[representation]:
                error = abs(found[representation][term] - value) / abs(value)
                parts.append(f"{term}: {error:.1%}")
            else:
                error = 1.0
                parts.append(f"{term}: missing")
            worst = error if np.isnan(worst) else max(worst, error)
        break
    text = "; ".join(parts) + (" (first order)" if parts and truth.first_order else "")
    return text or DASH, worst


def most_changed_equation(model: CellModel, start: CellModel, x: np.ndarray, u: np.ndarray) -> str:
    """The state whose rate differs most between two models on samples x, u: the rms difference over the
    starting model's std of that rate ("none" where no rate differs)."""
    with np.errstate(all="ignore"):
        a, b = model.rhs(x, u).reshape(-1, 8), start.rhs(x, u).reshape(-1, 8)
    change = np.sqrt(np.nanmean((a - b) ** 2, axis=0)) / (np.nanstd(b, axis=0) + 1e-300)
    return STATES[int(np.nanargmax(change))] if np.nanmax(change) > 0 else "none"


def score(
    case: str,
    method: str,
    answer: Answer,
    truth: Truth,
    true_equations: Sequence[str],
    start: CellModel,
    x: np.ndarray,
    u: np.ndarray,
    gap: pd.DataFrame,
    floor: float,
    window: str = "long",
) -> dict[str, Any]:
    """The table row of one method on one case; ``gap`` has rows 'starting model' and 'corrected model'."""
    changed = changed_equations(answer["model"], start, x, u)
    allowed = None if truth.variables is None or truth.also is None else truth.variables | truth.also
    variables: set[str] = set()
    spurious = 0
    for representation, equations, term, _ in answer["terms"]:
        reads = correction_variables(representation, term)
        variables |= reads
        outside = not set(equations or changed) & set(true_equations)
        spurious += bool(outside or (allowed is not None and not reads <= allowed))
    if not answer["terms"]:
        right = DASH
    elif truth.variables is None or not truth.variables:
        right = DASH if truth.variables is None else "no"
    else:
        common = truth.variables & variables
        right = "yes" if common == truth.variables else "partly" if common else "no"
    errors, worst = _coefficients(answer, truth)
    long = gap[gap["window"] == window].set_index("model")
    before = float(long.loc["starting model", "error"])
    corrected = "corrected model" if "corrected model" in long.index else "starting model"
    after = float(long.loc[corrected, "error"])
    closed = min(1.0, (before - after) / (before - floor)) if before > floor else np.nan
    return {
        "case": case,
        "method": method,
        "named": " then ".join(answer["named"])
        if answer["named"]
        else (DASH if answer["named"] is None else "nothing"),
        "equations_changed": " ".join(changed) or "none",
        "most_changed": most_changed_equation(answer["model"], start, x, u),
        "true_equations": " ".join(true_equations) or "none",
        "right_variables": right,
        "coefficient_errors": errors,
        "max_coefficient_error": worst,
        "spurious_terms": spurious,
        "terms": len(answer["terms"]),
        "error_before": before,
        "error_after": after,
        "noise_floor": floor,
        "gap_closed_above_floor": closed,
        "blowups": int(long.loc[corrected, "blowups"]),
        "rollouts": int(long.loc[corrected, "rollouts"]),
        "seconds": round(float(answer["seconds"]), 1),
        "correction": answer["correction"] or "none",
    }
