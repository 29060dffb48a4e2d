"""A sparse search's first round as separate jobs: the screen, shares of its fits, and a gather.

The screen (channel tests, every hypothesis screened) and each candidate's fit are the
expensive steps of a round on a pot line's record, and the fits are independent given the
screen, on either route (the filter's, :mod:`.filter.search`, or shooting, :mod:`.shooting.round`).
The workflow runs the screen as one job, the fits as ``jobs`` jobs (job j fits
candidates j, j + jobs, ...), and the discovery job gathers them, decides the round and
runs any later round itself: ``--cores N`` or a cluster spreads one case.  The records
written between them hold numbers only (a hypothesis by its key, a closed form by its terms'
names); the corrected models are rebuilt from them, so the rounds are the same whatever the
split, and the same as in one process.
"""

from __future__ import annotations

import dataclasses
import pickle
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ...physics import CellModel
from ..core.hypotheses import candidate_hypotheses
from .filter.search import Screen
from .innovations import ChannelTest, LoneCell, LostCell
from .observations import Observations
from .rounds import HypothesisScore, SparseCandidate
from .shooting.fit import ShootingFit
from .shooting.round import ShotFit, ShotScreen
from .shooting.screen import ScreenedForm

__all__ = [
    "read_fits", "read_screen", "read_shot_fits", "read_shot_screen", "write_fits", "write_screen",
    "write_shot_fits", "write_shot_screen",
]  # fmt: skip


def _score_record(score) -> dict[str, Any]:
    return {f.name: getattr(score, f.name) for f in dataclasses.fields(score) if f.name != "hypothesis"} | {
        "hypothesis": score.hypothesis.key
    }


def _score(record: dict[str, Any], hypotheses: dict) -> HypothesisScore:
    return HypothesisScore(**(record | {"hypothesis": hypotheses[record["hypothesis"]]}))


def write_screen(screen: Screen, start, path: str | Path) -> None:
    """The screen and the first states the starting model placed the cells at, ``start`` (n, 8) or None."""
    record = {
        "tests": [dataclasses.asdict(t) for t in screen.tests],
        "log_likelihood": screen.log_likelihood,
        "states": screen.states,
        "candidates": [_score_record(s) for s in screen.candidates],
        "others": [_score_record(s) for s in screen.others],
        "screened": screen.screened,
        "seed": screen.seed,
        "start": start,
        "left_out": _lone_record(screen.left_out),
        "lost": [dataclasses.asdict(c) for c in screen.lost],
    }
    Path(path).write_bytes(pickle.dumps(record))


def read_screen(path: str | Path, model: CellModel) -> tuple[Screen, Any]:
    """The screen (its candidates' hypotheses those of ``model``) and the searched start."""
    record = pickle.loads(Path(path).read_bytes())
    hypotheses = {h.key: h for h in candidate_hypotheses(model)}
    start = record.pop("start")
    record["tests"] = [ChannelTest(**t) for t in record["tests"]]
    record["candidates"] = [_score(s, hypotheses) for s in record["candidates"]]
    record["others"] = [_score(s, hypotheses) for s in record["others"]]
    record["left_out"] = _lone(record.get("left_out"))
    record["lost"] = [LostCell(**c) for c in record["lost"]]
    return Screen(**record), start


def write_fits(fits: Sequence[SparseCandidate], indices: Sequence[int], path: str | Path) -> None:
    """Fitted candidates (the screen's ``indices``) as numbers: the corrected model and the
    observations it was placed in are rebuilt on reading."""
    records = []
    for index, c in zip(indices, fits, strict=True):
        fields = {f.name: getattr(c, f.name) for f in dataclasses.fields(c)}
        fields |= {
            "score": _score_record(c.score),
            "features": [f.name for f in c.features],
            "corrected": None,
            "placed": None if c.placed is None else c.placed.start,
        }
        records.append((index, fields))
    Path(path).write_bytes(pickle.dumps(records))


def read_fits(paths: Sequence[str | Path], model: CellModel, obs: Observations) -> list[SparseCandidate]:
    """Every fitted candidate of the fit jobs' records, in the screen's order, rebuilt on ``model``
    and the observations ``obs`` (each placed at the start it searched itself)."""
    hypotheses = {h.key: h for h in candidate_hypotheses(model)}
    fits = []
    for _, fields in _rows(paths):
        score = _score(fields["score"], hypotheses)
        h = score.hypothesis
        library = {f.name: f for f in h.features(False)}
        features = [library[name] for name in fields["features"]]
        candidate = SparseCandidate(**(fields | {"score": score, "features": features, "placed": None}))
        if candidate.log_likelihood is not None:  # fitted and tested: from the start it searched itself
            candidate.placed = dataclasses.replace(obs, start=fields["placed"])
            candidate.corrected = h.corrected(model, features, candidate.coefficients)
        fits.append(candidate)
    return fits


def _form_record(form: ScreenedForm) -> dict[str, Any]:
    fields = {f.name: getattr(form, f.name) for f in dataclasses.fields(form)}
    return fields | {"hypothesis": form.hypothesis.key, "features": [f.name for f in form.features]}


def _form(record: dict[str, Any], hypotheses: dict) -> ScreenedForm:
    h = hypotheses[record["hypothesis"]]
    library = {f.name: f for f in h.features(rich=True)}
    return ScreenedForm(**(record | {"hypothesis": h, "features": tuple(library[n] for n in record["features"])}))


def write_shot_screen(screen: ShotScreen, start, path: str | Path) -> None:
    """The shooting route's screen (:func:`.shooting.round.screen_by_shooting`) as numbers, and the first
    states the starting model placed the cells at, ``start`` (n, 8)."""
    position = {id(f): i for i, f in enumerate(screen.forms)}
    record = {
        "tests": [dataclasses.asdict(t) for t in screen.tests],
        "base": None if screen.base is None else dataclasses.asdict(screen.base),
        "forms": [_form_record(f) for f in screen.forms],
        "candidates": [position[id(f)] for f in screen.candidates],
        "left_out": _lone_record(screen.left_out),
        "lost": [dataclasses.asdict(c) for c in screen.lost],
        "start": start,
    }
    Path(path).write_bytes(pickle.dumps(record))


def read_shot_screen(path: str | Path, model: CellModel) -> tuple[ShotScreen, Any]:
    """The shooting route's screen, its hypotheses those of ``model``, and the searched start."""
    record = pickle.loads(Path(path).read_bytes())
    hypotheses = {h.key: h for h in candidate_hypotheses(model)}
    forms = [_form(f, hypotheses) for f in record["forms"]]
    base = None if record["base"] is None else ShootingFit(**record["base"])
    tests = [ChannelTest(**t) for t in record["tests"]]
    screen = ShotScreen(
        tests=tests, base=base, forms=forms, candidates=[forms[i] for i in record["candidates"]],
        left_out=_lone(record["left_out"]), lost=[LostCell(**c) for c in record["lost"]],
    )  # fmt: skip
    return screen, record["start"]


def _lone_record(lone: LoneCell | None) -> dict | None:
    return None if lone is None else dataclasses.asdict(lone)


def _lone(record: dict | None) -> LoneCell | None:
    return None if record is None else LoneCell(**(record | {"hours": tuple(record["hours"])}))


def write_shot_fits(fits: Sequence[ShotFit], indices: Sequence[int], path: str | Path) -> None:
    """Shooting fits of the screen's candidates ``indices``, as numbers."""
    records = [
        (index, dataclasses.asdict(fit.fit), fit.covariance, [dataclasses.asdict(t) for t in fit.tests])
        for index, fit in zip(indices, fits, strict=True)
    ]
    Path(path).write_bytes(pickle.dumps(records))


def read_shot_fits(paths: Sequence[str | Path]) -> list[ShotFit]:
    """Every shooting fit of the fit jobs' records, in the screen's candidates' order."""
    return [
        ShotFit(fit=ShootingFit(**fit), covariance=covariance, tests=[ChannelTest(**t) for t in tests])
        for _, fit, covariance, tests in _rows(paths)
    ]


def _rows(paths: Sequence[str | Path]) -> list[tuple]:
    """The fit jobs' records' rows (each led by its candidate's index), in the screen's order."""
    rows = sorted((row for path in paths for row in pickle.loads(Path(path).read_bytes())), key=lambda r: r[0])
    if [row[0] for row in rows] != list(range(len(rows))):
        raise ValueError(f"the fit records {list(map(str, paths))} do not hold each candidate once")
    return rows
