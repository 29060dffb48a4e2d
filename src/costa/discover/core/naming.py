"""Which of equally good explanations is named, and how a correction's effect is put in words."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from ...observe import SENSED_PART, observe
from ...physics import BALANCES, PART_ORDER, PROPERTIES, CellModel
from ...variables import INPUTS
from .hypotheses import PREFERENCE, Hypothesis, same_sensitivity
from .outcome import Decision, Round
from .settings import DiscoverySettings

__all__ = [
    "alike", "balance_moved", "causes_through", "chain", "chain_rivals", "conclude", "decide", "explains_enough", "fit_outcome",
    "naming_order",
    "removal", "same_physics", "settled", "small_form_error", "unfitted_chain",
]  # fmt: skip

#: two corrections whose changes of the state rates differ by less than this share are the same physics
SAME_PHYSICS = 0.05


def _consequences(h: Hypothesis, reads: Mapping[str, frozenset[str]]) -> set[str]:
    """The parts computed from what ``h`` corrects, directly or through other parts: from a
    part, from an input, or from the constants a property rescales.  ``reads``: what each part
    reads (:meth:`CellModel.reads`).  A flow added to a balance is computed from nothing."""
    if h.kind == "property":
        sources = set(PROPERTIES[h.target].exponents)
    elif h.kind in ("part", "input"):
        sources = {h.target}
    else:
        return set()
    return _computed_from(sources, reads)


def _computed_from(sources: set[str], reads: Mapping[str, frozenset[str]], passing: str | None = None) -> set[str]:
    """The parts computed from ``sources``, directly or through other parts, not through part ``passing``."""
    computed: set[str] = set()
    for name in PART_ORDER:  # the computation order: one pass follows every chain
        if name != passing and reads[name] & (sources | computed):
            computed.add(name)
    return computed


def removal(share: float, excess: str = "the excess") -> str:
    """What a correction does to ``excess`` (the excess over noise it removes, ``share`` of it), in
    words: a negative share is an excess the correction made larger."""
    return f"adds {-share:.0%} to {excess}" if share < 0 else f"removes {share:.0%} of {excess}"


def small_form_error(removed: float, left: Sequence[float], settings: DiscoverySettings) -> bool:
    """Whether a correction that leaves channels beyond their noise is still named, its closed form
    "incomplete" (the rule of both sparse routes): it removes ``settings.form_removed`` of the
    uncorrected model's excess (``removed``, a share) and leaves the measured channels, on average, no
    more than ``settings.form_excess`` noise variances beyond their noise (``left``: each channel's, in
    noise variances).  Hundreds of thousands of samples flag such an error, most in the channel most
    sensitive to it (a saturating flow fitted by a linear form left the cell voltage at 1.6 noise
    variances and the rest near noise); a correction that leaves 50 times the noise variance, though it
    removed 96 % of a far larger excess, is not one."""
    return removed >= settings.form_removed and float(np.mean(left or [0.0])) <= settings.form_excess


def explains_enough(explained: float, bic_gain: float, settings: DiscoverySettings) -> bool:
    """Whether the best correction, removing ``explained`` (a share) of the flagged channels' or equations'
    excess and gaining ``bic_gain`` of BIC, explains enough to be an explanation at all: it removes
    ``settings.min_explained`` of the excess and gains ``settings.min_gain`` of BIC.  Otherwise the round is
    unexplained and the correction not applied, on every route (on sparse data the share is the filter's
    on every cell, :func:`..sparse.innovations.explained_share`: a transfer fitted by shooting to two
    cells' noise added to the pot voltage's excess on the others and was named wrongly)."""
    return explained >= settings.min_explained and bic_gain >= settings.min_gain


def conclude(*, left: bool, tolerated: bool, undecided: bool) -> Decision:
    """What a round concludes whose best correction explains enough of the disagreement (before this:
    nothing beyond noise, quiet; no correction that explains enough, unexplained), the rule every route
    follows, in this order:

    1. the best correction leaves a channel (or equation) beyond its noise (``left``) and its form
       error is not small (``tolerated``: :func:`small_form_error`): unexplained, whatever else fits as
       well (what is missing may be an explanation that did not fit, or more than one effect);
    2. a fit of other physics is as good, or a hypothesis the screen could not exclude was not
       fitted (``undecided``): not identifiable (the best correction applied, nothing named);
    3. named, its form incomplete where it leaves channels beyond noise.

    The full-state route passes ``left`` False: its next round tests what a closed form left, with
    the richer term library, where a sparse route's next round would explain what is left of a guess."""
    if left and not tolerated:
        return Decision.UNEXPLAINED
    if undecided:
        return Decision.NOT_IDENTIFIABLE
    return Decision.FORM_INCOMPLETE if left else Decision.NAMED


def settled(rounds: Sequence[Round]) -> list[Round]:
    """The rounds with every name a later round does not confirm withdrawn, the last rule of every route.

    A named hypothesis gets the first claim on what its correction leaves (:func:`naming_order`; on full
    states by a margin, ``new_mechanism_margin``).  A later round that corrects a channel (or equation)
    the named round flagged too, yet chooses another hypothesis, must confirm the name's physics: its
    choice acts alike (:func:`.hypotheses.same_sensitivity`: a heat flow into the bath and the bath's heat
    of freezing) and it tells its choice from the rest (identifiable).  Otherwise the richer search
    explains the same disagreement by other physics, or cannot tell, and the data do not single out
    the earlier name (a metal flow fitted first as the metal production, then, with products of
    states, as well by a flow from the cryolite or the ledge): that round becomes not identifiable, its
    correction still applied (the corrections and the later rounds are unchanged).  ``rounds``: rounds
    whose ``flagged`` lists the channels or equations they flagged."""
    out = list(rounds)
    for i, r in enumerate(out):
        if r.named is None:
            continue
        for later in out[i + 1 :]:
            shared = [c for c in later.flagged if c in r.flagged]
            if later.chosen is None or not shared or later.chosen.hypothesis.key == r.named.key:
                continue
            if later.identifiable and same_sensitivity(r.named, later.chosen.hypothesis, later.model):
                continue
            out[i] = dataclasses.replace(
                r, decision=Decision.NOT_IDENTIFIABLE,
                verdict=f"{r.verdict}; not named: a later round explains what it left in {', '.join(shared)} by "
                f"{later.chosen.hypothesis.key}{'' if later.identifiable else ' and its rivals'}, so the data "
                "do not single it out",
            )  # fmt: skip
            break
    return out


def naming_order(items: Sequence, named: Sequence[str], reads, terms=lambda item: 0) -> list:
    """Equally good explanations (items with a ``hypothesis``) in the order they are named: one
    refining an effect named in an earlier round; then the cause before its consequences (a part
    computed from another explanation's part, input or property comes after it, and so does a
    correction fitted as a constant times one input whose gain is among them: it is that gain);
    then fewest terms (``terms(item)``); then an input before an added flow, a transfer, a part
    and a property; then the earliest computed part (the order listed, for the other kinds)."""
    downstream = set().union(*(_consequences(item.hypothesis, reads) for item in items))
    gains = {item.hypothesis.target for item in items if item.hypothesis.kind == "input"}

    def key(item) -> tuple:
        h = item.hypothesis
        order = {"part": PART_ORDER, "property": tuple(PROPERTIES), "input": INPUTS}.get(h.kind, (h.target,))
        read = [f.name for f in getattr(item, "features", ())]
        consequence = (h.kind == "part" and h.target in downstream) or (
            h.kind != "input" and len(read) == 1 and read[0] in gains
        )
        return (h.key not in named, consequence, terms(item), PREFERENCE[h.kind], order.index(h.target))

    return sorted(items, key=key)


def same_physics(a: CellModel, b: CellModel, model: CellModel, x: np.ndarray, u: np.ndarray) -> bool:
    """Whether two corrections of ``model`` change every state rate alike at the states x (..., 8) and
    inputs u (..., 5): then no measurement of the states could tell them apart (a tapping gain and the
    same flow in the metal balance; a flow into the bath energy balance and the same change of the
    electric power)."""
    with np.errstate(all="ignore"):
        base = model.rhs(x, u)
        da, db = (c.rhs(x, u) - base for c in (a, b))
    scale = np.nanmax(np.abs(np.concatenate([da, db])).reshape(-1, 8), axis=0) + 1e-300
    difference = np.linalg.norm(np.nan_to_num((da - db) / scale))
    size = max(np.linalg.norm(np.nan_to_num(da / scale)), np.linalg.norm(np.nan_to_num(db / scale)), 1e-300)
    return bool(difference / size < SAME_PHYSICS)


def decide(close: Sequence, named: Sequence[str], model: CellModel, x: np.ndarray, u: np.ndarray) -> tuple:
    """Which of the explanations the data call equally good (``close``: items with a ``hypothesis``,
    ``features`` and ``corrected`` model) would be named, and whether the data name it: the rule
    every route follows.  Returns (chosen, others, rivals): the first in :func:`naming_order`
    (``named``: the keys earlier rounds named), the others in that order, and those of them whose
    physics differs from the chosen one's (not :func:`alike` at the states x (..., 8) and inputs u
    (..., 5)).  While a rival stands, nothing is named (and a route fits every hypothesis
    its screen cannot exclude before it decides): the chosen correction is the best fit, not the
    cause (a flow into the AlF3 balance and a transfer from the ledge to it fit alike where the
    ledge's side of the transfer is below its noise)."""
    x, u = x.reshape(-1, 8), u.reshape(-1, 5)
    with np.errstate(all="ignore"):
        reads = model.reads(x[:1], u[:1])
    chosen, *others = naming_order(close, named, reads, terms=lambda c: len(c.features))
    return chosen, others, [c for c in others if not alike(c, chosen, model, x, u)]


def alike(a, b, model: CellModel, x: np.ndarray, u: np.ndarray) -> bool:
    """Whether two fitted explanations (items with a ``hypothesis`` and a ``corrected`` model) are one
    explanation to the data: their corrections change every state rate alike at the states x and inputs
    u (:func:`same_physics`), or their hypotheses act alike at every operating point, whatever their
    closed forms (:func:`.hypotheses.same_sensitivity`: a constant heat loss fitted as the bath's heat
    of freezing and one in proportion to the electric power are both a heat flow missing from the bath;
    the data tell the forms apart only by the margin the naming rule allows)."""
    return same_physics(a.corrected, b.corrected, model, x, u) or same_sensitivity(a.hypothesis, b.hypothesis, model)


#: what a sensor reads through the model's parts, not as a state: a correction that changes one of
#: these is not a flow missing from a balance, whatever it does to the rates
DERIVED_READINGS = ("U_cell", "m_tap")


def balance_moved(corrected: CellModel, model: CellModel, x: np.ndarray, u: np.ndarray) -> str | None:
    """The balance whose rate alone ``corrected`` changes from ``model``'s at the states x (..., 8) and
    inputs u (..., 5), where it changes no reading computed from the parts (:data:`DERIVED_READINGS`):
    then it is, to any measurement, that much flow missing from that balance (a constant change of
    the bath's heat of freezing is a heat loss from the bath).  The other states' changes are
    compared in units of how much each state's rate varies over x and u; None where they are not
    below :data:`SAME_PHYSICS` of the one changed, or the readings change."""
    with np.errstate(all="ignore"):
        base = model.rhs(x, u).reshape(-1, 8)
        change = corrected.rhs(x, u).reshape(-1, 8) - base
        readings = (observe(m, x, u, DERIVED_READINGS) for m in (model, corrected))
        if not np.allclose(*readings, rtol=1e-9, atol=0.0, equal_nan=True):
            return None
    size = np.linalg.norm(np.nan_to_num(change / (np.nanstd(base, axis=0) + 1e-300)), axis=0)
    moved = int(size.argmax())
    if size[moved] == 0 or np.delete(size, moved).max() >= SAME_PHYSICS * size[moved]:
        return None
    return next(balance for balance, (state, _) in BALANCES.items() if state == f"x{moved + 1}")


def causes_through(part: str, model: CellModel, x: np.ndarray, u: np.ndarray) -> list[str]:
    """The parts computed before ``part`` whose every effect on the state rates and the sensed voltage
    passes through it, and that move it at each of the states x (..., 8) and inputs u (..., 5) where it
    is finite: any correction of ``part`` is then, point by point, one of each of them, and no
    measurement tells which.  (The direction may differ between points: the bubble coverage's formula
    has a pole at 2.06 % alumina, across which the bubble voltage turns.)  The bath
    conductivity g2, the bubbles' coverage g3 and thickness g4 and their voltage g5 act on the cell only
    through its voltage U = g5 + u2 u5 / (2620 g2); the liquidus temperature, read by the freezing rate
    and the ledge's heat flows, acts through none of them alone."""
    reads = model.reads(x[:1], u[:1])
    sinks = model.flow_reads(x[:1], u[:1]) | {SENSED_PART}
    with np.errstate(all="ignore"):
        before = model.quantities(x, u)[part]
    causes = []
    for cause in PART_ORDER[: PART_ORDER.index(part)]:
        reached = {cause} | _computed_from({cause}, reads, passing=part)
        if reached & sinks or not reached & reads[part]:
            continue
        p = model.parts[cause]
        bumped = model.with_part(cause, p.renamed(f"1.01 ({p.formula})", lambda v, k, q, p=p: 1.01 * p(v, k, q)))
        with np.errstate(all="ignore"):
            moved = (bumped.quantities(x, u)[part] - before)[np.isfinite(before)]
        if np.isfinite(moved).all() and (moved != 0).all():
            causes.append(cause)
    return causes


def chain(part: str, model: CellModel, x: np.ndarray, u: np.ndarray) -> list[str]:
    """The parts no measurement tells from ``part`` by a free correction, in the order computed: those
    that act on the cell only through it (:func:`causes_through`), those it acts on the cell only
    through (each later part that has it among its causes), and so on from each of them.  A
    correction of one is, point by point, a correction of each other, so only their closed forms
    tell them apart: the bubbles' thickness acts on the cell only through the cell voltage, which
    the bath conductivity alone moves too, so the conductivity's law is a law of the thickness."""
    reads = {q: causes_through(q, model, x, u) for q in PART_ORDER}
    linked, frontier = {part}, [part]
    while frontier:
        p = frontier.pop()
        for q in [*reads[p], *(q for q in PART_ORDER if p in reads[q])]:
            if q not in linked:
                linked.add(q)
                frontier.append(q)
    return [q for q in PART_ORDER if q in linked and q != part]


def unfitted_chain(
    chosen: Hypothesis, fitted: Sequence[Hypothesis], model: CellModel, x: np.ndarray, u: np.ndarray
) -> list[Hypothesis]:
    """The parts of ``chosen``'s :func:`chain` (a part's; none for other kinds) that act unlike ``chosen``
    and every hypothesis ``fitted`` (:func:`.hypotheses.same_sensitivity`: a fit of the bubble voltage is
    one of the cell voltage, which moves the cell identically): each explains the data at least as well
    as ``chosen`` with a free correction, so a name stands only where every one was fitted and lost by
    the margin (every route's rule; the full-state route fits them all).  States x (..., 8), inputs u
    (..., 5)."""
    if chosen.kind != "part":
        return []
    parts = (
        Hypothesis(key=f"part:{name}", kind="part", target=name, unit=model.parts[name].unit)
        for name in chain(chosen.target, model, x.reshape(-1, 8), u.reshape(-1, 5))
    )
    return [p for p in parts if not any(same_sensitivity(p, h, model) for h in (chosen, *fitted))]


def chain_rivals(
    candidates: Sequence[Hypothesis], available: Sequence[Hypothesis], model: CellModel, x: np.ndarray, u: np.ndarray
) -> list[Hypothesis]:
    """The hypotheses of ``available`` in the part ``candidates``' chains (:func:`unfitted_chain`) that act
    unlike every candidate and each other, in the candidates' order: with a free correction each explains
    the data as well as its candidate, so no screen can exclude them and a round fits them beside the
    candidates (on conductivity_alf3's pot-line record the bubbles' coverage screened first and the bath
    conductivity it stands for was not fitted).  States x (..., 8), inputs u (..., 5)."""
    keys = {h.key for h in available}
    added: list[Hypothesis] = []
    for c in candidates:
        for h in unfitted_chain(c, [*candidates, *added], model, x, u):
            if h.key in keys and not any(same_sensitivity(h, a, model) for a in added):
                added.append(h)
    return added


def fit_outcome(fitted: bool, explained: float, scored: bool) -> str:
    """What a candidate's correction did to the flagged channels' excess, in words, or why it has
    none: not ``fitted`` (no term held, or its filter was lost on half the cells or more, by its free
    delta and on the channels alike), or not ``scored`` (the corrected filter lost a cell that the
    uncorrected model's holds)."""
    if not fitted:
        return "could not be fitted (no term held, or its filter was lost on half the cells or more by both routes)"
    effect = removal(explained)
    return effect if scored else f"{effect}, but its filter is lost on a cell the uncorrected model's holds"
