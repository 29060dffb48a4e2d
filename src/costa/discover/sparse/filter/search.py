"""Discovery rounds on partial, sparse measurements: test the channels, rank, fit, correct, repeat.

One round on the current model:

1. the smoother's innovations of every measured channel are tested for variance, bias
   and whiteness (:func:`..estimator.innovation_tests`); nothing flagged -> stop;
2. every hypothesis gets a random-walk delta(t) in the smoother and is scored, on a few
   trajectories that the uncorrected filter holds (:func:`screened_trajectories`), by the
   log-likelihood it gains (:func:`.likelihood.score_hypotheses`; one whose delta's filter is
   lost there, by its one-term form refined on them, :func:`_lost_scored_on_channels`);
   the best ``partial_candidates`` go on, one of each group of the same physics
   (:func:`distinct_physics`);
3. each of those is smoothed on all trajectories (one whose filter is lost on half of
   them or more is fitted by the other route: its one-term forms refined on the measured
   channels, :func:`_fitted_on_channels`), its delta(t) regressed on the physical
   terms (:mod:`...core.library`) evaluated at the smoothed states, window by window, with one
   bootstrap over blocks of trajectories for selection and intervals (a term is kept
   only if its :data:`...core.fitted_terms.KEEP_LEVEL` interval excludes zero), and the corrected
   model scored by the BIC gain of its own likelihood of the measured channels, as the
   full-data route scores a correction by its exact residual;
4. corrections within ``equivalence`` BIC of the best explain the measured channels
   equally well (the window widened by the best correction's remaining misfit,
   :func:`_dispersion`: where even the best leaves the innovations far from white, BIC
   differences are not evidence).  If they are one explanation (:func:`...core.naming.alike`:
   their effects on every state rate proportional, or their hypotheses acting alike: a flow
   into the bath's energy balance and a change of the electric power), the cause is named as
   on full data.  If not, the measurements
   cannot tell them apart: the round says so, names none, lists them and says which
   unmeasured channel would separate them; the best one still corrects the model for
   forecasting, and the rounds stop there; so too where a hypothesis that was not fitted
   could still explain them (its free delta gained, on the screened trajectories, within the margin
   of what the chosen closed form gains there: :func:`could_explain_as_well`): each such is fitted
   and the round decided again, to ``partial_fits`` fits (:func:`with_unexcluded`), and those still
   left are listed; and where a
   candidate of other physics gained more than the chosen one in the screen, fitted or not: the
   chosen one then leads only by the term library's closed forms (:func:`_screened_ahead`);
5. terms cannot buy a name: the chosen correction's closed form, cut to each rival's (fewer)
   terms and refined again, must still beat that rival (of different physics) by the
   equivalence margin, or the two are undecided as in 4 (:func:`at_budget`);
6. a named correction whose closed form leaves a channel slightly disagreeing (hundreds of
   thousands of samples make a small form error significant) stays named where it removes
   ``form_removed`` of the flagged excess and leaves the channels, on average, within ``form_excess``
   noise variances of noise, and the verdict says "form incomplete" with what
   is left; the rounds stop there.  One that leaves more is unexplained, before 4 and 5 are
   asked (:func:`...core.naming.conclude`, the order of every route);
7. a round the basic term library leaves unexplained is fitted again with the richer one (every
   square and pairwise product of the main variables) and decided by 4-6 again; that decision stands
   where it is not unexplained too (:func:`decided_round`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from ....compiled import Smoothed
from ....physics import CellModel
from ...core.fitted_terms import KEEP_LEVEL, weakest_term
from ...core.hypotheses import Hypothesis, candidate_hypotheses, same_sensitivity
from ...core.library import FIRST_ORDER, FLOW_INPUTS, Feature, constant_inputs
from ...core.naming import (
    alike,
    chain_rivals,
    conclude,
    decide,
    explains_enough,
    fit_outcome,
    naming_order,
    removal,
    small_form_error,
    unfitted_chain,
)
from ...core.outcome import Decision
from ...core.regression import GramSystem, coefficient_samples, independent_columns, selected_in_half, solve_subset
from ...core.settings import DiscoverySettings
from ..innovations import ChannelTest, LoneCell, LostCell, explained_share, innovation_excess
from ..measure_next import Recommendation, measure_next, separating, to_separate
from ..observations import Observations
from ..rounds import (
    BudgetComparison,
    HypothesisScore,
    SparseCandidate,
    SparseRound,
    best_first,
    channel_tests,
    likelihood_gains,
    round_tests,
)
from .likelihood import (
    CONVERGED,
    MAX_PASSES,
    Refined,
    mostly_lost,
    refine_coefficients,
    score_hypotheses,
    smooth_hypothesis,
)

__all__ = [
    "Screen",
    "at_budget",
    "chained",
    "could_explain_as_well",
    "decide_round",
    "discover_sparse",
    "distinct_physics",
    "fit_share",
    "other_physics",
    "screen_round",
    "with_unexcluded",
]

log = logging.getLogger(__name__)

#: two hypotheses whose changes of the state rates, each at a constant delta, differ by less than this
#: share (rounding) are one fit: unlike fitted corrections, no closed form can tell them apart
SAME_EFFECT = 1e-4
#: hypotheses that are a relative change (an input's gain, a material property's factor): their
#: constant alone is a whole closed form, a fixed relative error, tried beside the regression's
RELATIVE_KINDS = ("input", "property")


def _dispersion(ranking: Sequence[SparseCandidate]) -> float:
    """The best correction's remaining misfit: the mean square of its standardised innovations over
    every measured sample (at least 1).  Where even the best leaves the channels far from white
    noise, the likelihood is misspecified, and differences of BIC shrink by this factor before they
    count as evidence (a quasi-likelihood, as QAIC divides by the overdispersion c-hat)."""
    tests = ranking[0].tests_after if ranking else []
    samples = sum(t.samples for t in tests)
    return max(1.0, sum(t.chi2_per_dof * t.samples for t in tests) / samples) if samples else 1.0


def _feature_values(
    h: Hypothesis, model: CellModel, features: Sequence[Feature], x: np.ndarray, u: np.ndarray
) -> np.ndarray:
    """The features' values (n, K, P) at the states x (n, K, 8) and inputs u (n, K, 5), one trajectory at a time."""
    return np.concatenate([h.feature_values(model, features, x[i : i + 1], u[i : i + 1]) for i in range(len(x))])


def _closed_form(
    h: Hypothesis, model: CellModel, smoothed: Smoothed, obs: Observations, settings: DiscoverySettings, rng, rich: bool
):
    """Select and fit the terms of delta(t) (the smoothed delta, window means weighted by their
    information) with one bootstrap for what is kept and what is reported."""
    library = h.features(rich)
    x, delta, std = smoothed.mean[..., :8], smoothed.mean[..., 8], smoothed.std[..., 8]
    n, steps = delta.shape
    window = settings.window
    a = steps // window
    cut = a * window
    theta = _feature_values(h, model, library, x[:, :cut], obs.u[:, :cut])
    means = theta.reshape(n, a, window, -1).mean(2)
    target = delta[:, :cut].reshape(n, a, window).mean(2)
    weight = 1.0 / np.sqrt(np.maximum((std[:, :cut] ** 2).reshape(n, a, window).mean(2), 1e-300))
    held = np.isfinite(means).all((1, 2)) & np.isfinite(target).all(1) & np.isfinite(weight).all(1)
    weight[~held] = 0.0  # a trajectory whose filter was lost says nothing of delta
    means[~held], target[~held] = 0.0, 0.0
    rows = np.nan_to_num(means * weight[..., None]).reshape(-1, len(library))
    independent = independent_columns(rows)  # a constant part's own value duplicates the constant term
    library, rows = [library[i] for i in independent], rows[:, independent]
    per_block = max(1, int(np.ceil(a / settings.blocks_per_trajectory)))
    groups = (np.arange(n)[:, None] * settings.blocks_per_trajectory + np.arange(a)[None, :] // per_block).ravel()
    system = GramSystem.from_design(rows, np.nan_to_num(target * weight).ravel(), groups)
    weights, inclusion, terms = selected_in_half(
        system, settings.bootstrap, rng, max_terms=settings.max_terms, min_gain=settings.min_gain
    )
    G, b, _, _ = system.total()
    while (weakest := weakest_term(samples := coefficient_samples(system, terms, weights), KEEP_LEVEL)) is not None:
        terms.pop(weakest)
    inclusion_by_name = {f.name: float(p) for f, p in zip(library, inclusion, strict=True) if p > 0}
    return [library[i] for i in terms], solve_subset(G, b, terms), samples, inclusion_by_name


def _refined(
    h: Hypothesis, model: CellModel, obs: Observations, settings: DiscoverySettings, *, fit, smoothed: Smoothed,
    rich: bool, rng,
):  # fmt: skip
    """The closed form ``fit`` (features, coefficients, samples) refined on the measured channels
    (:func:`.likelihood.refine_coefficients`), with samples of their posterior in place of the bootstrap's.

    Beside the selected terms, the library's flow inputs (the feed and tapping, one-step doses)
    and its first-order terms (:data:`...core.library.FIRST_ORDER`) are refined: a delta proportional to
    a dose is a train of spikes that the smoothed random walk spreads out, so the regression
    cannot see it, but the measured channels can; and where the regression on a delta smoothed
    from sparse samples picked a proxy (the superheat for a rate that rises with the temperature
    and the AlF3 content), the channels weigh it against the variables it stands for.  Each
    added term starts at 0, with a prior width (five times its samples' spread) that makes it
    twice as large as the smoothed delta (mean absolute values over the data).  The terms whose
    interval then covers zero are dropped (all but the best alone, :func:`_best_alone`, where
    that is every one) and the rest refined again, in one pass linearised at
    the coefficients already refined (all at once: each pass is a run of the filter over every
    trajectory).  Unchanged where the refinement is not trustworthy."""
    original, succeeded = fit, False
    features, coefficients, samples = fit
    names = {f.name for f in features}
    added = [f for f in h.features(rich) if f.name in FLOW_INPUTS + FIRST_ORDER and f.name not in names]
    if added:
        size = np.nanmean(np.abs(smoothed.mean[..., 8]))
        values = _feature_values(h, model, added, smoothed.mean[..., :8], obs.u)
        typical = np.nanmean(np.abs(values.reshape(-1, len(added))), axis=0)
        features = [*features, *added]
        coefficients = np.append(coefficients, np.zeros(len(added)))
        spread = 0.4 * size / np.maximum(typical, 1e-300)  # the prior width below, 5 spreads: twice the delta
        samples = np.column_stack([samples, rng.standard_normal((len(samples), len(added))) * spread])
    while features:
        width = _prior_width(coefficients, samples)
        refined = refine_coefficients(
            model, h, features=features, coefficients=coefficients, width=width, obs=obs, passes=1 if succeeded else 2
        )
        if refined is None:
            return (features, coefficients, samples) if succeeded else original
        coefficients, succeeded = refined.coefficients, True
        samples = rng.multivariate_normal(coefficients, refined.covariance, size=len(samples), method="eigh")
        unneeded = _covering_zero(samples)
        if 1 < len(unneeded) == len(features):
            best = _best_alone(h, model, obs, settings, features=features, coefficients=coefficients, samples=samples)
            unneeded.remove(best)
            log.info("%s: every term covers zero; %s fits best alone and stays", h.key, features[best].name)
        if not unneeded:
            break
        keep = [i for i in range(len(features)) if i not in unneeded]
        features, coefficients, samples = [features[i] for i in keep], coefficients[keep], samples[:, keep]
    return features, coefficients, samples


def _prior_width(coefficients: np.ndarray, samples: np.ndarray) -> np.ndarray:
    """The prior width of each coefficient (P,) refined on the measured channels: half its size or five
    times the spread of its ``samples`` (draws, P), whichever is larger."""
    return np.maximum(0.5 * np.abs(coefficients), 5 * samples.std(axis=0)) + 1e-300


def _strength(coefficients: np.ndarray, samples: np.ndarray) -> np.ndarray:
    """Each term's |coefficient| over the spread of its posterior ``samples`` (draws, P)."""
    return np.abs(coefficients) / (samples.std(axis=0) + 1e-300)


def _covering_zero(samples: np.ndarray) -> list[int]:
    """The terms whose interval (:data:`KEEP_LEVEL` of the posterior ``samples``, (draws, terms)) covers zero."""
    low, high = np.quantile(samples, [(1 - KEEP_LEVEL) / 2, (1 + KEEP_LEVEL) / 2], axis=0)
    return [i for i in range(samples.shape[1]) if low[i] <= 0 <= high[i]]


def _best_alone(
    h: Hypothesis, model: CellModel, obs: Observations, settings: DiscoverySettings, *, features,
    coefficients: np.ndarray, samples: np.ndarray,
) -> int:  # fmt: skip
    """Of terms that each cover zero, the one that, refined alone, corrects the model best by the
    round's own score (the measured channels' likelihood from the start the corrected model searches
    itself, on the most trajectories held): terms that stand in for one another (a constant and a
    slow state) can each cover zero while together they carry the correction (a tapping shortfall
    pooled on 5 pots: every term dropped in one pass, the constant at -0.101), and which of them is
    strongest over its spread is chance.  The strongest where none refines alone."""
    width, scores = _prior_width(coefficients, samples), {}
    for i, f in enumerate(features):
        alone = refine_coefficients(
            model, h, [f], coefficients=coefficients[i : i + 1], width=width[i : i + 1], obs=obs
        )
        if alone is not None:
            corrected = h.corrected(model, [f], alone.coefficients)
            _, after = channel_tests(corrected, obs.searched_again(corrected), settings, backward=False)
            held = np.isfinite(after.log_likelihood)
            scores[i] = (int(held.sum()), float(after.log_likelihood[held].sum()))
    if not scores:
        return int(np.argmax(_strength(coefficients, samples)))
    return max(scores, key=scores.get)


def best_screened(screened: Sequence[HypothesisScore], settings: DiscoverySettings) -> list[HypothesisScore]:
    """The screened hypotheses (best first) that go on to a fit: the best ``partial_candidates``
    and those tied exactly with the last of them, each with a gain or a trajectory held where the
    uncorrected filter diverged.  A gain of minus infinity (a trajectory lost that the uncorrected
    filter holds) is no tie: on plant data every hypothesis holding as many lost cells would
    otherwise go on (conductivity_alf3: 14 fits in place of 4)."""
    top = list(screened[: settings.partial_candidates])
    ties = [
        s for s in screened[len(top) :] if top and s.rank_key == top[-1].rank_key and np.isfinite(s.log_likelihood_gain)
    ]
    return [s for s in top + ties if s.log_likelihood_gain > 0 or s.rescued > 0]


def distinct_physics(
    scores: Sequence[HypothesisScore], model: CellModel, x: np.ndarray, u: np.ndarray, named: Sequence[str] = ()
) -> list[HypothesisScore]:
    """One of each group of screened hypotheses that change every state rate alike, to rounding, at
    the states x (N, 8) and inputs u (N, 5), each shifted by its own scale: the same physics (an
    added flow in the AlF3 balance and the same change of a part that enters only that balance),
    whose fits would be the same fit.  Not hypotheses that differ by a factor that varies with the
    state (the ACD, the bath's conductivity and the bubbles all change the voltage, but in
    proportions that vary with the line current and the composition): their closed forms differ.
    The one kept is the one :func:`...core.naming.naming_order` names first; the order of the groups is
    that of their best member."""
    groups = _physics_groups(scores, model, x, u)
    reads = model.reads(x[:1], u[:1])
    kept = [naming_order([scores[i] for i in g], named, reads)[0] for g in groups]
    for g, first in zip(groups, kept, strict=True):
        if len(g) > 1:
            log.info(
                "fitted once as %s, the same physics: %s", first.hypothesis.key, [scores[i].hypothesis.key for i in g]
            )
    return kept


def chained(
    candidates: Sequence[HypothesisScore], screened: Sequence[HypothesisScore], model: CellModel, x, u
) -> list[HypothesisScore]:
    """The ``screened`` hypotheses of the part candidates' chains that are not candidates, one of each
    sensitivity (:func:`...core.naming.chain_rivals`): a round fits them beside the candidates."""
    by_key = {s.hypothesis.key: s for s in screened if np.isfinite(s.log_likelihood_gain)}
    rivals = chain_rivals([c.hypothesis for c in candidates], [s.hypothesis for s in by_key.values()], model, x, u)
    if rivals:
        log.info("fitted beside the candidates, their chains: %s", [h.key for h in rivals])
    return [by_key[h.key] for h in rivals]


def other_physics(
    screened: Sequence[HypothesisScore], candidates: Sequence[HypothesisScore], model: CellModel, x, u
) -> list[HypothesisScore]:
    """The ``screened`` hypotheses (best first) with a finite positive gain that are not fitted, of other
    physics than every candidate: the best of each group of the same physics (:func:`distinct_physics`)."""
    rest = [
        s for s in screened if s not in candidates and np.isfinite(s.log_likelihood_gain) and s.log_likelihood_gain > 0
    ]
    scores = [*candidates, *rest]
    return [scores[g[0]] for g in _physics_groups(scores, model, x, u) if g[0] >= len(candidates)]


def _physics_groups(
    scores: Sequence[HypothesisScore], model: CellModel, x: np.ndarray, u: np.ndarray
) -> list[list[int]]:
    """The indices of ``scores`` in groups of the same physics (:func:`distinct_physics`), each in order."""
    with np.errstate(all="ignore"):
        base = model.rhs(x, u)
        effects = [np.nan_to_num(s.hypothesis.shifted(model, s.scale).rhs(x, u) - base) for s in scores]
    groups: list[list[int]] = []
    for i, effect in enumerate(effects):
        group = next((g for g in groups if _proportional(effect, effects[g[0]])), None)
        if group is None:
            groups.append([i])
        else:
            group.append(i)
    return groups


def _proportional(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether two changes of the state rates (N, 8) are proportional (either sign) to rounding
    (:data:`SAME_EFFECT`), each state's rate in units of the larger change of it."""
    scale = np.maximum(np.abs(a), np.abs(b)).max(axis=0) + 1e-300
    a, b = (a / scale).ravel(), (b / scale).ravel()
    norms = np.linalg.norm(a), np.linalg.norm(b)
    if min(norms) == 0:
        return False
    a, b = a / norms[0], b / norms[1]
    return bool(min(np.linalg.norm(a - b), np.linalg.norm(a + b)) < SAME_EFFECT)


def _fit(
    score: HypothesisScore,
    model: CellModel,
    obs: Observations,
    settings: DiscoverySettings,
    seed,
    rich: bool,
    tests: list[ChannelTest],
    first: bool,
    states: np.ndarray,
) -> SparseCandidate:
    """Smooth one hypothesis on every trajectory, fit its closed form, refine its coefficients on the
    measured channels, test the corrected model's innovations and keep its likelihood (scored
    against the other candidates by :func:`_score`); in the ``first`` round, one term alone where
    it scores better (:func:`_one_term_if_better`).  Every candidate of a round resamples with
    the same ``seed``.  A hypothesis whose free delta's filter is lost on half the trajectories or
    more is fitted by the other route: its one-term forms refined from zero on the measured channels
    (:func:`_fitted_on_channels`), sized on the uncorrected model's ``states`` (n, K/16, 8)."""
    started = time.perf_counter()
    smoothed = smooth_hypothesis(model, score, obs, settings.window)
    rng = np.random.default_rng(seed)
    if mostly_lost(np.isfinite(smoothed.mean).all((1, 2))):
        log.info("%s: its free delta's filter is lost on half the trajectories or more", score.hypothesis.key)
        return _fitted_on_channels(score, model, obs, settings, states=states, tests=tests, rich=rich, rng=rng)
    *fit, inclusion = _closed_form(
        score.hypothesis, model, smoothed=smoothed, obs=obs, settings=settings, rng=rng, rich=rich
    )
    features, coefficients, _ = fit
    placed = obs.searched_again(score.hypothesis.corrected(model, features, coefficients)) if features else obs
    features, coefficients, samples = _refined(
        score.hypothesis, model, placed, settings, fit=fit, smoothed=smoothed, rich=rich, rng=rng
    )
    candidate = SparseCandidate(
        score=score,
        states=smoothed.mean[..., :8],
        features=features,
        coefficients=coefficients,
        samples=samples,
        inclusion=inclusion,
    )
    if not features:
        log.info("%s: no term held in the refinement, not fitted", score.hypothesis.key)
        return candidate
    corrected = score.hypothesis.corrected(model, features, coefficients)
    candidate.placed = obs.searched_again(corrected)
    tests_after, after = channel_tests(corrected, candidate.placed, settings, backward=False)
    candidate.corrected, candidate.tests_after, candidate.log_likelihood = corrected, tests_after, after.log_likelihood
    if first:
        _one_term_if_better(candidate, model, obs, settings, smoothed=smoothed, rich=rich, rng=rng)
    flagged = [t.channel for t in tests if t.flagged]
    candidate.explained = explained_share(tests, candidate.tests_after, flagged)
    log.info(
        "%s: %s, log-likelihood %.1f, in %.1f s",
        score.hypothesis.key, candidate.formula, np.sum(candidate.log_likelihood), time.perf_counter() - started,
    )  # fmt: skip
    return candidate


def _one_term_if_better(
    candidate: SparseCandidate, model: CellModel, obs: Observations, settings: DiscoverySettings, *,
    smoothed: Smoothed, rich: bool, rng,
) -> None:  # fmt: skip
    """Replace the candidate's closed form by one term (:func:`_single_terms`, each refined alone on the
    measured channels until it converges), where the best of them scores better by the round's own
    measure (2 log-likelihood - terms x ln(samples), on as many trajectories held).  The regression on
    the smoothed delta follows the filter's errors as well as the effect, and the refinement only drops
    terms: on a 30-day pot fed 92 %, a 7-term form in c2, c3 and x6 was kept where the gain's
    constant alone, -0.0798 (the truth -0.08), fits 5,500 log-likelihood units better; on three pots
    of a line fed 92 %, pooled, one term 13 (c2 - 0.03)(x6 - 970) where the constant, -0.0800, fits
    46,000 better; on three pots whose bath conductivity falls with AlF3 as exp(-3.5 (c3 - 0.11)),
    pooled, the regression reached a seventh of the slope and every form of the voltage's chain left
    x6 and c3 beyond noise, where own (c3 - 0.11) refined alone reaches -3.4 and leaves every channel
    within noise.  The first round only: in a later round a constant flow stands in for what is left
    of an earlier round's closed form (the liquidus law named from partial records lost its name to a
    constant bath-ledge transfer)."""
    h = candidate.score.hypothesis
    samples = int(np.isfinite(obs.y).sum())
    alone = (
        _refined_alone(h, term, model, obs, settings, smoothed=smoothed)
        for term in _single_terms(h, rich)
        if [f.name for f in candidate.features] != [term.name]
    )
    best = _highest_scoring(alone, samples, _alone_score(candidate.log_likelihood, len(candidate.features), samples))
    if best is None:
        return
    coefficient = best.refined.coefficients[0]
    log.info("%s: %s alone, %.4g, scores better than %s", h.key, best.term.name, coefficient, candidate.formula)
    best.given_to(candidate, rng)


def _alone_score(likelihood: np.ndarray, terms: int, samples: int) -> tuple[int, float]:
    """A closed form's score by the round's own measure: the trajectories its filter holds, then
    2 log-likelihood (per trajectory, (n,)) - ``terms`` x ln(``samples``) on those."""
    held = np.isfinite(likelihood)
    return int(held.sum()), 2 * float(likelihood[held].sum()) - terms * np.log(max(samples, 2))


def _highest_scoring(alone: Iterable[_Alone | None], samples: int, floor: tuple[int, float] | None) -> _Alone | None:
    """Of terms refined ``alone`` (None: the refinement failed), the last that scores highest by
    :func:`_alone_score` on ``samples`` measured values, at least ``floor`` (None: any); None where none does."""
    best, best_score = None, floor
    for a in alone:
        if a is not None and (best_score is None or _alone_score(a.log_likelihood, 1, samples) >= best_score):
            best, best_score = a, _alone_score(a.log_likelihood, 1, samples)
    return best


def _single_terms(h: Hypothesis, rich: bool) -> list[Feature]:
    """The terms tried alone in a first round: an input's gain or a property's factor, the constant; a
    part's, its relative first order (its own value alone and times each of :data:`FIRST_ORDER`'s
    variables: the part in proportion to itself, as a coefficient that varies with the bath); none
    for a flow."""
    library = {f.name: f for f in h.features(rich)}
    if h.kind in RELATIVE_KINDS:
        names = ["1"]
    elif h.kind == "part":
        names = ["own", *(f"own*{name}" for name in FIRST_ORDER[1:])]
    else:
        names = []
    return [library[name] for name in names if name in library]


class _Alone(NamedTuple):
    """One term refined alone (:func:`_refined_alone`): the term, its refinement, the model it corrects,
    the observations that model placed, its channel tests and per-trajectory log-likelihood (n,)."""

    term: Feature
    refined: Refined
    corrected: CellModel
    placed: Observations
    tests: list[ChannelTest]
    log_likelihood: np.ndarray

    def given_to(self, candidate: SparseCandidate, rng) -> None:
        """Make this term ``candidate``'s closed form, with as many samples of its posterior as it had."""
        coefficients, covariance = self.refined
        candidate.features, candidate.coefficients = [self.term], coefficients
        candidate.samples = rng.multivariate_normal(
            coefficients, covariance, size=len(candidate.samples), method="eigh"
        )
        candidate.corrected, candidate.placed = self.corrected, self.placed
        candidate.tests_after, candidate.log_likelihood = self.tests, self.log_likelihood


def _refined_alone(
    h: Hypothesis, term: Feature, model: CellModel, obs: Observations, settings: DiscoverySettings, *,
    smoothed: Smoothed,
) -> _Alone | None:  # fmt: skip
    """One ``term`` refined alone from its least-squares fit to the smoothed delta, with a prior width of
    half that or of the delta's spread in the term's units, whichever is larger; None where the
    refinement fails."""
    delta = smoothed.mean[..., 8]
    values = _feature_values(h, model, [term], smoothed.mean[..., :8], obs.u)[..., 0]
    finite = np.isfinite(delta) & np.isfinite(values)
    delta, values = delta[finite], values[finite]
    start = np.array([np.sum(delta * values) / max(float(np.sum(values**2)), 1e-300)])
    spread = float(np.std(delta)) / max(float(np.mean(np.abs(values))), 1e-300)
    width = np.maximum(0.5 * np.abs(start), spread) + 1e-300
    return _alone_from(h, term, model, obs, settings, start=start, width=width)


def _alone_from(
    h: Hypothesis, term: Feature, model: CellModel, obs: Observations, settings: DiscoverySettings, *,
    start: np.ndarray, width: np.ndarray,
) -> _Alone | None:  # fmt: skip
    """One ``term`` refined alone on the measured channels from ``start`` (1,) with the prior ``width``
    (1,), until it converges, and the corrected model's tests; None where the refinement fails."""
    placed = obs.searched_again(h.corrected(model, [term], start))
    refined = refine_coefficients(model, h, [term], start, width, placed, passes=MAX_PASSES, converged=CONVERGED)
    if refined is None:
        return None
    corrected = h.corrected(model, [term], refined.coefficients)
    placed = obs.searched_again(corrected)
    tests, after = channel_tests(corrected, placed, settings, backward=False)
    return _Alone(term, refined, corrected, placed, tests, after.log_likelihood)


def _best_from_zero(
    score: HypothesisScore, model: CellModel, obs: Observations, settings: DiscoverySettings, *,
    states: np.ndarray, rich: bool,
) -> _Alone | None:  # fmt: skip
    """The best-scoring (:func:`_alone_score`) of a hypothesis' one-term forms (:func:`_single_terms`; a
    flow's constant), each refined from zero on the measured channels (:func:`_alone_from`) with the prior
    width of the screen's scale over the term's mean size on the uncorrected model's ``states`` (n, K/16, 8,
    every 16th step); None where none refines."""
    h, u = score.hypothesis, obs.u[:, ::16]  # the states' steps

    def from_zero(term: Feature) -> _Alone | None:
        size = float(np.nanmean(np.abs(_feature_values(h, model, [term], states, u))))
        if not np.isfinite(size) or size <= 0:
            return None
        width = np.array([score.scale / size]) + 1e-300
        return _alone_from(h, term, model, obs, settings, start=np.zeros(1), width=width)

    terms = _single_terms(h, rich) or [f for f in h.features(rich) if f.name == "1"]
    return _highest_scoring(map(from_zero, terms), int(np.isfinite(obs.y).sum()), None)


def _fitted_on_channels(
    score: HypothesisScore, model: CellModel, obs: Observations, settings: DiscoverySettings, *,
    states: np.ndarray, tests: list[ChannelTest], rich: bool, rng,
) -> SparseCandidate:  # fmt: skip
    """A hypothesis whose free delta's filter is lost, fitted by the other route: each of its one-term
    forms (:func:`_single_terms`; a flow's constant) refined from zero on the measured channels
    (:func:`_alone_from`), with the prior width of the screen's scale (the delta that moves the most
    sensitive channel by its noise over a window; held over a record, far more than its noise) over the
    term's typical size on the uncorrected model's ``states`` (n, K/16, 8, every 16th step).  The one
    that scores best (:func:`_alone_score`) is the candidate's form, with its smoothed states; no terms
    where none refines.  The free delta follows the effect and the filter's errors alike: on a pot
    line's daily samples it lets a mass reach zero in hours and the filter gives up, where a closed
    form fitted on the channels holds every cell (dev pot_line 2: a constant ledge-AlF3 transfer,
    refined from 30 scales, lost its cells too; from 3 or 0.3, -0.00214 or -0.00224 kg/s)."""
    h = score.hypothesis
    candidate = SparseCandidate(
        score=score, states=states, features=[], coefficients=np.zeros(0), samples=np.zeros((settings.bootstrap, 0)),
        inclusion=None,
    )  # fmt: skip
    best = _best_from_zero(score, model, obs, settings, states=states, rich=rich)
    if best is None:
        log.info("%s: no one-term form refines on the channels either, not fitted", h.key)
        return candidate
    best.given_to(candidate, rng)
    _, smoothed = channel_tests(best.corrected, best.placed, settings)
    candidate.states = smoothed.mean[..., :8]
    candidate.explained = explained_share(tests, best.tests, [t.channel for t in tests if t.flagged])
    log.info(
        "%s: fitted on the channels instead, %s %.4g, log-likelihood %.1f", h.key, best.term.name,
        best.refined.coefficients[0], np.sum(best.log_likelihood),
    )  # fmt: skip
    return candidate


def _cut(candidate: SparseCandidate, budget: int, model: CellModel, settings: DiscoverySettings) -> np.ndarray:
    """Per-trajectory log-likelihood (n,) of ``candidate``'s closed form cut to its ``budget``
    strongest terms (largest |coefficient| over its posterior spread), refined again on the
    measured channels and scored from the start the cut model searches itself."""
    h, samples = candidate.hypothesis, candidate.samples
    strength = _strength(candidate.coefficients, samples)
    keep = np.sort(np.argsort(-strength, kind="stable")[:budget])
    features, coefficients = [candidate.features[i] for i in keep], candidate.coefficients[keep]
    width = _prior_width(coefficients, samples[:, keep])
    refined = refine_coefficients(
        model, h, features=features, coefficients=coefficients, width=width, obs=candidate.placed
    )
    if refined is not None:
        coefficients = refined.coefficients
    corrected = h.corrected(model, features, coefficients)
    _, after = channel_tests(corrected, candidate.placed.searched_again(corrected), settings, backward=False)
    return after.log_likelihood


def at_budget(
    chosen: SparseCandidate,
    rivals: Sequence[SparseCandidate],
    model: CellModel,
    settings: DiscoverySettings,
    base_likelihood: np.ndarray,
    samples: int,
    margin: float,
) -> list[BudgetComparison]:
    """The chosen correction against each rival with fewer terms, at the rival's budget (one cut
    form per budget): a lead that a closed form's extra terms bought does not name it.  A rival
    the cut form does not beat by ``margin`` BIC (or that holds more lost trajectories) is
    ``matched``."""
    budgets = sorted({len(r.features) for r in rivals})
    cuts = {b: _cut(chosen, b, model, settings) for b in budgets}
    comparisons = []
    for rival in rivals:
        b = len(rival.features)
        (gain,), (held,) = likelihood_gains(cuts[b][None], base_likelihood)
        chosen_gain = 2 * gain - b * np.log(samples) if np.isfinite(gain) else -np.inf
        matched = bool(held < rival.rescued or chosen_gain - rival.bic_gain <= margin)
        comparisons.append(
            BudgetComparison(
                rival=rival.hypothesis.key,
                terms=b,
                chosen_gain=float(chosen_gain),
                rival_gain=rival.bic_gain,
                matched=matched,
            )
        )
        against = f"{rival.hypothesis.key}'s {rival.bic_gain:.1f}" + " (matched)" * matched
        log.info("%s cut to %d terms: BIC gain %.1f against %s", chosen.hypothesis.key, b, chosen_gain, against)
    return comparisons


def _score(candidates: Sequence[SparseCandidate], base_likelihood: np.ndarray, samples: int) -> None:
    """Each fitted candidate's BIC gain over the uncorrected model on ``samples`` measured values, and
    the trajectories it holds where the uncorrected filter diverged (:func:`..rounds.likelihood_gains`)."""
    fitted = [c for c in candidates if c.log_likelihood is not None]
    if not fitted:
        return
    gains, rescued = likelihood_gains(np.stack([c.log_likelihood for c in fitted]), base_likelihood)
    for c, gain, held in zip(fitted, gains, rescued, strict=True):
        c.rescued = int(held)
        c.bic_gain = 2 * gain - len(c.features) * np.log(samples) if np.isfinite(gain) else -np.inf


@dataclass
class Screen:
    """A round's channel tests and screen: what its fits and its decision read.  ``candidates``
    go on to a fit, each with ``seed``; ``log_likelihood`` (n,) and ``states`` (n, K/16, 8), every
    16th step, are the uncorrected model's filter."""

    tests: list[ChannelTest]
    log_likelihood: np.ndarray
    states: np.ndarray
    candidates: list[HypothesisScore]
    seed: int
    # the hypotheses not fitted, of other physics than every candidate (:func:`other_physics`), and the
    # trajectories they were screened on (:func:`screened_trajectories`)
    others: list[HypothesisScore] = field(default_factory=list)
    screened: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    # a cell that alone disagreed (left out of the tests) and the cells lost (:func:`..rounds.round_tests`)
    left_out: LoneCell | None = None
    lost: list[LostCell] = field(default_factory=list)

    @property
    def flagged(self) -> list[str]:
        return [t.channel for t in self.tests if t.flagged]


def screen_round(
    model: CellModel, obs: Observations, settings: DiscoverySettings, rng: np.random.Generator, named: Sequence[str]
) -> Screen:
    """Test the channels; where one disagrees, screen every hypothesis and keep the best of each
    physics (steps 1-2 of the module docstring).  Draws the round's fitting seed from ``rng``."""
    tests, base, left_out, lost = round_tests(model, obs, settings)
    states = base.mean[:, ::16, :8]
    if not any(t.flagged for t in tests):
        return Screen(
            tests=tests, log_likelihood=base.log_likelihood, states=states, candidates=[], seed=0, left_out=left_out,
            lost=lost,
        )  # fmt: skip
    rows = screened_trajectories(base.log_likelihood, max(1, settings.screen_steps // obs.y.shape[1]))
    few, few_states = obs.subset(rows), base.mean[rows]
    started = time.perf_counter()
    screened, _ = score_hypotheses(
        model,
        candidate_hypotheses(model, constant_inputs(obs.u)),
        obs=few,
        window=settings.window,
        states=few_states,
        walks=settings.walks,
    )
    log.info(
        "screened %d hypotheses on trajectories %s in %.1f s; the best: %s", len(screened), rows.tolist(),
        time.perf_counter() - started, ", ".join(f"{s.hypothesis.key} {s.log_likelihood_gain:.4g}" for s in screened[:12]),
    )  # fmt: skip
    screened = _lost_scored_on_channels(
        screened, model, few, settings, base=base.log_likelihood[rows], states=few_states[:, ::16, :8]
    )
    seed = int(rng.integers(2**63))
    screen_x, screen_u = (a[:, ::16].reshape(-1, a.shape[-1]) for a in (few_states, few.u))
    candidates = distinct_physics(best_screened(screened, settings), model, screen_x, screen_u, named)
    candidates += chained(candidates, screened, model, screen_x, screen_u)
    return Screen(
        tests=tests, log_likelihood=base.log_likelihood, states=states, candidates=candidates, seed=seed,
        others=other_physics(screened, candidates, model, screen_x, screen_u), screened=rows, lost=lost,
    )  # fmt: skip


def screened_trajectories(base: np.ndarray, n: int) -> np.ndarray:
    """The ``n`` trajectories a round screens its hypotheses on: the first whose uncorrected filter holds (its
    log-likelihood ``base`` (trajectories,) finite), then the first lost ones where too few hold.  A screen is a
    comparison with the uncorrected filter, and a lost one compares nothing (dev pot_line 21: its one screened
    cell lost, each hypothesis was compared there with the best of them, not with the model)."""
    held_first = np.argsort(~np.isfinite(base), kind="stable")
    return np.sort(held_first[:n])


def _lost_scored_on_channels(
    screened: Sequence[HypothesisScore], model: CellModel, few: Observations, settings: DiscoverySettings, *,
    base: np.ndarray, states: np.ndarray,
) -> list[HypothesisScore]:  # fmt: skip
    """The ``screened`` hypotheses (best first) with those whose free delta lost a screened trajectory that
    the uncorrected filter (per-trajectory log-likelihood ``base``) holds scored instead by their best
    one-term form refined from zero on the screened trajectories' channels (:func:`_best_from_zero`): a lost
    filter excludes nothing (dev pot_line 11: a constant AlF3 flow, its free delta lost, unranked, and the
    AlF3 feed's gain named in its place)."""
    lost = [s for s in screened if not np.isfinite(s.log_likelihood_gain)]
    if not lost or not np.isfinite(base).all():
        return list(screened)
    started, scored = time.perf_counter(), {}
    for s in lost:
        best = _best_from_zero(s, model, few, settings, states=states, rich=False)
        if best is not None:
            (gain,), _ = likelihood_gains(best.log_likelihood[None], base)
            scored[s.hypothesis.key] = replace(s, log_likelihood_gain=float(gain))
    log.info(
        "%d hypotheses lost the screen's filter; scored on the channels in %.1f s: %s", len(lost),
        time.perf_counter() - started, ", ".join(f"{k} {v.log_likelihood_gain:.4g}" for k, v in scored.items()),
    )  # fmt: skip
    rescored = [scored.get(s.hypothesis.key, s) for s in screened]
    return best_first(rescored)


def fit_share(
    screen: Screen, model: CellModel, obs: Observations, settings: DiscoverySettings, rich: bool, share: slice,
    first: bool,
) -> list[SparseCandidate]:  # fmt: skip
    """The screen's candidates in ``share`` (e.g. ``slice(j, None, jobs)``: job j of ``jobs``), each fitted;
    ``first``: whether this is the first round."""
    return [_fit_screened(s, model, obs, settings, screen, rich=rich, first=first) for s in screen.candidates[share]]


def discover_round(
    model: CellModel, obs: Observations, *, settings: DiscoverySettings, rng: np.random.Generator,
    named: Sequence[str] = (),
) -> SparseRound:  # fmt: skip
    """One round on the current model (see the module docstring); ``named``: what earlier rounds named."""
    screen = screen_round(model, obs, settings, rng, named)
    fits = fit_share(screen, model, obs=obs, settings=settings, rich=False, share=slice(None), first=not named)
    return decided_round(model, obs, settings=settings, screen=screen, fits=fits, named=named)


def decided_round(
    model: CellModel, obs: Observations, *, settings: DiscoverySettings, screen: Screen,
    fits: list[SparseCandidate], named: Sequence[str] = (),
) -> SparseRound:  # fmt: skip
    """The round :func:`decide_round` decides from the basic term library's ``fits``; where that leaves it
    unexplained (no closed form explains enough, or the best leaves channels beyond noise), the screen's
    candidates fitted again with the richer library (every square and pairwise product of the main
    variables: a law that reads two variables the basic library does not pair) decide it, where they
    end it otherwise: named or not identifiable by the same rules, rivals fitted alike."""
    found, fits = with_unexcluded(model, obs, settings=settings, screen=screen, fits=fits, named=named, rich=False)
    found = replace(found, lost=screen.lost)
    if found.decision is not Decision.UNEXPLAINED or not fits:
        return found
    refitted = [_fit_screened(c.score, model, obs, settings, screen, rich=True, first=not named) for c in fits]
    richer, _ = with_unexcluded(model, obs, settings=settings, screen=screen, fits=refitted, named=named, rich=True)
    log.info("the richer term library: %s", richer.verdict)
    if richer.decision is Decision.UNEXPLAINED:
        return replace(found, verdict=f"{found.verdict}; so too with the richer term library")
    return replace(richer, rich=True, lost=screen.lost)


def with_unexcluded(
    model: CellModel, obs: Observations, *, settings: DiscoverySettings, screen: Screen,
    fits: list[SparseCandidate], named: Sequence[str], rich: bool,
) -> tuple[SparseRound, list[SparseCandidate]]:  # fmt: skip
    """The round :func:`decide_round` decides from ``fits`` and, while it is undecided because the screen
    could not exclude a hypothesis that was not fitted (:func:`could_explain_as_well`), from those fitted
    too, to ``partial_fits`` fits in all: a name stands only where every one was fitted and lost by the
    margin (the rule of every route; a fit on a partial record takes seconds).  Also the fits it made."""
    others = {s.hypothesis.key: s for s in screen.others}
    while True:
        found = decide_round(model, obs, settings=settings, screen=screen, ranking=fits, named=named)
        # a chain part fitted to no term (none held, its filter lost) is listed still
        tried = {c.hypothesis.key for c in fits}
        left = [others[h.key] for h in found.not_fitted if h.key in others and h.key not in tried]
        room = settings.partial_fits - len(fits)
        if found.decision is not Decision.NOT_IDENTIFIABLE or not left or room <= 0:
            return found, fits
        log.info("the screen could not exclude %s: fitted too", [s.hypothesis.key for s in left[:room]])
        fits = fits + [_fit_screened(s, model, obs, settings, screen, rich=rich, first=not named) for s in left[:room]]


def _fit_screened(
    score: HypothesisScore, model: CellModel, obs: Observations, settings: DiscoverySettings, screen: Screen, *,
    rich: bool, first: bool,
) -> SparseCandidate:  # fmt: skip
    """One screened hypothesis fitted (:func:`_fit`) with the round's seed and channel tests."""
    return _fit(
        score, model, obs=obs, settings=settings, seed=screen.seed, rich=rich, tests=screen.tests, first=first,
        states=screen.states,
    )  # fmt: skip


def decide_round(
    model: CellModel,
    obs: Observations,
    settings: DiscoverySettings,
    screen: Screen,
    ranking: list[SparseCandidate],
    named: Sequence[str] = (),
) -> SparseRound:
    """Score the fitted candidates (``ranking``, in the screen's order) and decide what the round names
    (steps 3-6 of the module docstring)."""
    tests, flagged = screen.tests, screen.flagged
    if not flagged:
        return SparseRound.quiet(model, tests, screen.left_out)
    _score(ranking, screen.log_likelihood, int(np.isfinite(obs.y).sum()))
    ranking = sorted(ranking, key=lambda c: (-c.rescued, -c.bic_gain))
    dispersion = _dispersion(ranking)
    good = [
        c
        for c in ranking
        if c.features
        and c.rescued == ranking[0].rescued
        and ranking[0].bic_gain - c.bic_gain <= settings.equivalence * dispersion
    ]
    if not good or not explains_enough(good[0].explained, good[0].bic_gain, settings):
        verdict = f"unexplained: channels {flagged} disagree beyond noise, but no candidate explains them"
        if ranking:
            top = ranking[0]
            outcome = fit_outcome(bool(top.features), top.explained, bool(np.isfinite(top.bic_gain)))
            verdict += f": the best, {top.hypothesis.key}, {outcome}"
        fitted = [c for c in ranking if c.corrected is not None][:3]
        return SparseRound.unexplained_round(
            model,
            tests,
            ranking,
            verdict,
            measure_next=_next(fitted, obs, settings.equivalence * dispersion),
            dispersion=dispersion,
        )
    x = screen.states  # every 16th step
    chosen, equivalent, different = decide(good, named, model, x, obs.u[:, ::16])
    fewer = [
        c
        for c in ranking
        if c is not chosen
        and c not in equivalent
        and 0 < len(c.features) < len(chosen.features)
        and np.isfinite(c.bic_gain)
        and not alike(c, chosen, model, x, obs.u[:, ::16])
    ]
    samples = int(np.isfinite(obs.y).sum())
    margin = settings.equivalence * dispersion
    budget = (
        at_budget(
            chosen,
            fewer,
            model=model,
            settings=settings,
            base_likelihood=screen.log_likelihood,
            samples=samples,
            margin=margin,
        )
        if fewer
        else []
    )
    matched = [c for c, b in zip(fewer, budget, strict=True) if b.matched]
    unexplained = [t.channel for t in chosen.tests_after if t.flagged]
    outscreened = [c for c in _screened_ahead(chosen, ranking, model) if c not in good and c not in matched]
    undecided = different + matched + outscreened
    unfitted = [
        h
        for h in could_explain_as_well(chosen, screen, settings.equivalence * dispersion, ranking)
        if not same_sensitivity(h, chosen.hypothesis, model)
    ]
    fitted = [c.hypothesis for c in ranking if c.features]
    chained = [h for h in unfitted_chain(chosen.hypothesis, fitted, model, x, obs.u[:, ::16]) if h not in unfitted]
    if chained:
        log.info("%s: the parts of its chain %s were not fitted", chosen.hypothesis.key, [h.key for h in chained])
    decision = conclude(
        left=bool(unexplained),
        tolerated=_small_form_error(chosen, settings),
        undecided=bool(undecided or unfitted or chained),
    )
    recommended = []
    unfitted = unfitted + chained if decision is Decision.NOT_IDENTIFIABLE else []
    if decision is Decision.NOT_IDENTIFIABLE:
        recommended = _next(to_separate(chosen, undecided, ranking), obs, margin)
        keys = ", ".join(c.hypothesis.key for c in [chosen, *undecided])
        what = f"not identifiable: {keys} " + (
            "explain the measured channels equally well" if undecided else "fits best"
        )
        if matched:
            what += " (" + "; ".join(_budget_words(chosen, b) for b in budget if b.matched) + ")"
        if outscreened:
            what += (
                f" ({', '.join(c.hypothesis.key for c in outscreened)}: a free delta gained more in the screen than "
                f"{chosen.hypothesis.key}'s, which leads only by the term library's closed forms)"
            )
        if len(unfitted) > len(chained):
            listed = ", ".join(h.key for h in unfitted if h not in chained)
            what += f", and the screen could not exclude {listed}, not fitted"
        if chained:
            listed = ", ".join(h.key for h in chained)
            what += f", and {listed}, through which alone it acts or which act alone through it, not fitted"
        what += separating(recommended)
    elif decision is Decision.UNEXPLAINED:
        recommended = _next(to_separate(chosen, [], ranking), obs, margin)
        what = (
            f"unexplained: the best correction, {chosen.hypothesis.key}, leaves {unexplained} disagreeing beyond "
            "noise, so what is missing may be an explanation that did not fit here or more than one effect"
        )
    else:
        what = chosen.hypothesis.describe(model)
        if decision is Decision.FORM_INCOMPLETE:
            left = ", ".join(f"{t.channel} at {t.chi2_per_dof:.3g}" for t in chosen.tests_after if t.flagged)
            what += (
                f" (form incomplete: its closed form leaves {left} times the noise variance, "
                f"{1 - chosen.explained:.1%} of the flagged channels' excess)"
            )
    separated = recommended[0].channel if decision is Decision.NOT_IDENTIFIABLE and recommended else None
    listed = equivalent + undecided if decision is Decision.NOT_IDENTIFIABLE else equivalent  # its rivals too
    effect = removal(chosen.explained, "the flagged channels' excess")
    return SparseRound(
        model=model, tests=tests, ranking=ranking, chosen=chosen, equivalent=listed, decision=decision, separated_by=separated, verdict=f"{what}; the correction {effect}", dispersion=dispersion, at_budget=budget,
        measure_next=recommended, not_fitted=unfitted,
    )  # fmt: skip


def could_explain_as_well(
    chosen: SparseCandidate, screen: Screen, margin: float, fitted: Sequence[SparseCandidate] = ()
) -> list[Hypothesis]:
    """The hypotheses not ``fitted`` that the screen cannot exclude: a free delta along a hypothesis gains at
    least as much likelihood as any closed form of it (on top_heat_loss's partial record the four fitted
    closed forms gained 0.1-1.3 % less than their free deltas on the screened trajectories; not where delta(t)
    moves faster than the walk follows: dev 51's transfer form gained 512, its free delta 334), so one whose
    free delta falls short of the chosen closed form's gain on those trajectories by half the BIC
    ``margin`` cannot explain them as well; the others may.  A name stands only where none is left."""
    rows = screen.screened
    gains = chosen.log_likelihood[rows] - screen.log_likelihood[rows]
    lead = float(gains[np.isfinite(gains)].sum())  # where both filters held
    tried = {c.hypothesis.key for c in fitted}
    return [
        s.hypothesis
        for s in screen.others
        if not s.log_likelihood_gain < lead - margin / 2 and s.hypothesis.key not in tried
    ]


def _small_form_error(chosen: SparseCandidate, settings: DiscoverySettings) -> bool:
    """:func:`...core.naming.small_form_error` of the chosen correction: what it removes of the flagged
    channels' excess, and what it leaves of each channel beyond white unit noise (chi2/dof - 1 + bias^2)."""
    left = [innovation_excess([t], [t.channel]) for t in chosen.tests_after]
    return small_form_error(chosen.explained, left, settings)


def _screened_ahead(
    chosen: SparseCandidate, ranking: Sequence[SparseCandidate], model: CellModel
) -> list[SparseCandidate]:
    """The candidates of other physics than ``chosen`` (:func:`...core.hypotheses.same_sensitivity`) whose free
    delta gained more likelihood in the screen than ``chosen``'s, fitted or not: the data, before any closed form,
    prefer them, so ``chosen`` leads only where the term library holds their law and fits it worse, which a law
    outside it defeats (dev seed 601: a freezing rate with an exponential law, its free delta ahead by
    87 log-likelihood units, its transfer's closed form removing 15 % of the excess where the solid cryolite's heat
    capacity removed 72 % and left every channel at noise)."""
    lead = chosen.score.log_likelihood_gain
    return [
        c
        for c in ranking
        if c is not chosen
        and c.score.log_likelihood_gain > lead
        and not same_sensitivity(c.hypothesis, chosen.hypothesis, model)
    ]


def _next(candidates: Sequence[SparseCandidate], obs: Observations, margin: float) -> list[Recommendation]:
    """What to measure to tell the first candidate from the others (:func:`..measure_next.measure_next`):
    each seen through its corrected model, along the states its smoothed delta implies; ``margin`` in BIC."""
    return measure_next([(c.hypothesis.key, c.corrected, c.states) for c in candidates], obs, margin)


def _budget_words(chosen: SparseCandidate, b: BudgetComparison) -> str:
    """One budget comparison in words."""
    return (
        f"cut to {b.terms} term{'s' * (b.terms > 1)}, {chosen.hypothesis.key} gains {b.chosen_gain:.0f} BIC "
        f"against {b.rival}'s {b.rival_gain:.0f}"
    )


def discover_sparse(
    model: CellModel,
    obs: Observations,
    settings: DiscoverySettings,
    first_round: tuple[Screen, list[SparseCandidate]] | None = None,
) -> list[SparseRound]:
    """Rounds until no channel disagrees, nothing explains it, a correction explains too little,
    the measurements cannot tell the explanations apart, the best correction leaves a channel
    disagreeing (in both cases a further round would explain what is left of a guess), or
    ``max_rounds``.  Each round after the first runs from the start its model (the one corrected
    so far) searches itself, the one its correction was tested from (``placed``): from the
    uncorrected model's starts a right correction can look wrong, and a second round name an
    effect that is not there.  ``first_round``: the first round's screen and fits, made by
    separate jobs (:mod:`..split`); the rounds are the same as without."""
    rng = np.random.default_rng(settings.seed)
    rounds: list[SparseRound] = []
    current, placed = model, obs
    for index in range(settings.max_rounds):
        named = [r.chosen.hypothesis.key for r in rounds if r.chosen is not None]
        if index == 0 and first_round is not None:
            screen, fits = first_round
            if screen.candidates and int(rng.integers(2**63)) != screen.seed:
                raise ValueError("the first round's screen was made with another discovery seed; run it again")
            found = decided_round(current, placed, settings=settings, screen=screen, fits=fits, named=named)
        else:
            found = discover_round(current, placed, settings=settings, rng=rng, named=named)
        rounds.append(found)
        if found.named is None or found.form_incomplete:
            break
        current, placed = found.corrected, found.chosen.placed
    return rounds
