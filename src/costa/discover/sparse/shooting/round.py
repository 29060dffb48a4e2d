"""A round on a pot line's record decided by multiple shooting: every hypothesis screened, the best fitted.

On the shooting route (:mod:`costa.discover.route`: hand samples every shift or more often, the
composition not logged at every step), the first round runs:

1. the uncorrected model's channel tests, its filter's innovations on every cell, as on the
   filter route: nothing flagged -> stop;
2. on the first ``shooting_cells`` cells, the uncorrected model fitted by multiple shooting
   (:mod:`.fit`) and every hypothesis' closed form of at most three terms screened
   linearised at that fit (:func:`.screen.screen_forms`); the ``shooting_refine`` best by
   BIC gain and the ``shooting_refine`` best by the channels' predicted excess go on, with the parts
   of their chains (:func:`...core.naming.chain`: with free corrections, one explains the data as well
   as another), and every other the screen cannot exclude (:func:`not_excluded`), to ``shooting_fits``
   fits in all;
3. each of those fitted by shooting through the continuity stages to the filter's process noise
   (separate jobs: :mod:`..split`), with its coefficients' covariance and channel tests;
4. the fits ranked (:func:`.screen.ranked_fits`): the first is named where it leaves every
   channel at its noise, or removes nearly all of the excess ("form incomplete"), and no fit of
   other physics comes within :data:`.screen.MARGIN` of its BIC gain; a fit of other physics
   within it leaves the round undecided; one that leaves a channel beyond its noise unexplained;
   a hypothesis the screen could not exclude and that was not fitted, of other physics than the
   first, or a part of the first's chain that was not fitted, leaves it undecided too (listed: a
   name stands only where every such one was fitted), and so does a screen that excluded none
   (:func:`screen_told`: its best form gained less than ``min_gain`` of BIC).
   The best correction is applied either way where it removes at least ``min_explained`` of the
   excess, as on the filter route; where the best by BIC gain removes less of the flagged channels'
   excess on every cell, by its filter (:func:`filtered_share`), the round is unexplained whatever its
   fit's channels (:func:`...core.naming.explains_enough`, every route's rule); so too where the chosen
   correction gains nothing on the other cells (:func:`held_elsewhere`, on the cells both filters hold),
   and it is not applied: an effect missing from the model is missing in every cell.

Every closed form has at most three terms, so no rival holds a larger budget: a name is not bought
by terms.  A fit at noise on every channel leaves nothing for a further round on these cells, so the
route decides one round.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from types import SimpleNamespace

import numpy as np

from ....physics import CellModel
from ...core.hypotheses import Hypothesis, candidate_hypotheses
from ...core.library import constant_inputs
from ...core.naming import alike, chain_rivals, explains_enough, removal, unfitted_chain
from ...core.outcome import Decision
from ...core.settings import DiscoverySettings
from ..innovations import ChannelTest, LoneCell, LostCell, explained_share, innovation_tests
from ..measure_next import measure_next, separating, to_separate
from ..observations import Observations
from ..observed import start_is_searched
from ..rounds import HypothesisScore, SparseCandidate, SparseRound, channel_tests, round_tests
from .fit import CONTINUITY_STAGES, Segments, Shooting, ShootingFit, shooting_fit, states_eliminated
from .screen import MARGIN, FittedForm, ScreenedForm, ranked_fits, screen_forms

__all__ = [
    "ShotFit", "ShotScreen", "by_excess", "decide_by_shooting", "filtered_share", "fit_by_shooting", "gain_where_held",
    "held_elsewhere", "not_excluded", "screen_by_shooting", "screen_told", "screened_forms", "shooting_cells",
    "with_not_excluded",
]  # fmt: skip

log = logging.getLogger(__name__)

#: the segments' length [s]
SEGMENT_S = 3600.0


def shooting_cells(obs: Observations, cells: int) -> Observations:
    """The first ``cells`` cells, cut to whole segments."""
    steps = round(SEGMENT_S / obs.dt)
    used = (obs.y.shape[1] // steps) * steps
    return obs.subset(slice(0, cells)).steps(0, used)


@dataclass(frozen=True)
class ShotScreen:
    """The round's channel ``tests`` (every cell's filter); on the shooting cells, the uncorrected
    model's ``base`` fit at the last continuity stage, every hypothesis' screened form (``forms``, best
    BIC gain first) and the ``candidates`` among them that are fitted."""

    tests: list[ChannelTest]
    base: ShootingFit | None
    forms: list[ScreenedForm]
    candidates: list[ScreenedForm]
    # a cell that alone disagreed (left out of the tests) and the cells lost (:func:`..rounds.round_tests`)
    left_out: LoneCell | None = None
    lost: list[LostCell] = field(default_factory=list)

    @property
    def flagged(self) -> list[str]:
        return [t.channel for t in self.tests if t.flagged]

    def unfitted(self, window: float) -> list[ScreenedForm]:
        """The forms with terms the screen cannot exclude (:func:`not_excluded`) that were not fitted."""
        return [f for f in not_excluded(self.forms, window) if all(f is not c for c in self.candidates)]


@dataclass(frozen=True)
class ShotFit:
    """A candidate's shooting ``fit``, its coefficients' ``covariance`` (P, P) (the inverse of the
    Gauss-Newton information with the states eliminated) and its residuals' channel ``tests`` on the
    shooting cells, each flagged where the channel lies beyond its noise (:attr:`.fit.ShootingFit.beyond_noise`)."""

    fit: ShootingFit
    covariance: np.ndarray
    tests: list[ChannelTest]


def screen_by_shooting(model: CellModel, obs: Observations, settings: DiscoverySettings) -> ShotScreen:
    """Steps 1-2 of the module docstring; ``obs`` with each cell's first state searched under ``model``."""
    tests, _, left_out, lost = round_tests(model, obs, settings, backward=False)
    if not any(t.flagged for t in tests):
        return ShotScreen(tests=tests, base=None, forms=[], candidates=[], left_out=left_out, lost=lost)
    few = shooting_cells(obs, settings.shooting_cells)
    hypotheses = candidate_hypotheses(model, constant_inputs(obs.u))
    return ShotScreen(tests, *screened_forms(model, hypotheses, few, settings), lost=lost)


def screened_forms(
    model: CellModel, hypotheses: Sequence[Hypothesis], few: Observations, settings: DiscoverySettings
) -> tuple[ShootingFit, list[ScreenedForm], list[ScreenedForm]]:
    """On the shooting cells ``few``: the uncorrected model's fit at the last continuity stage, every
    hypothesis' screened form (best BIC gain first) and those that go on to a fit (step 2)."""
    iterations = settings.shooting_iterations
    base, forms = screen_forms(model, hypotheses, few, SEGMENT_S, iterations)
    base = shooting_fit(
        model,
        None,
        features=[],
        obs=few,
        segment_s=SEGMENT_S,
        iterations=iterations,
        starts=base.starts,
        stages=CONTINUITY_STAGES[1:],
    )
    top = settings.shooting_refine
    chosen = {id(f): f for f in forms[:top] + by_excess(forms)[:top] if f.features}
    x, u = base.starts.reshape(-1, 8), few.u[:, :: round(SEGMENT_S / few.dt)].reshape(-1, 5)
    by_key = {f.hypothesis.key: f for f in forms if f.features}
    rivals = chain_rivals([f.hypothesis for f in chosen.values()], [f.hypothesis for f in by_key.values()], model, x, u)
    if rivals:
        log.info("fitted beside the candidates, their chains: %s", [h.key for h in rivals])
    chosen |= {id(by_key[h.key]): by_key[h.key] for h in rivals}
    return base, forms, with_not_excluded(list(chosen.values()), forms, settings)


def with_not_excluded(
    chosen: Sequence[ScreenedForm], forms: Sequence[ScreenedForm], settings: DiscoverySettings
) -> list[ScreenedForm]:
    """``chosen`` and every form the screen cannot exclude (:func:`not_excluded`, best first), to
    ``shooting_fits`` in all.  A budget of 8 left three ledge heat hypotheses unfitted on the shipped
    top_heat_loss plant case and nine on wall_conductivity (the wall's temperature brings more heat
    hypotheses within the window); with 24 every one was fitted and both were named right (a fit job
    doubled, 32 to 60 s)."""
    out = {id(f): f for f in chosen}
    for form in not_excluded(forms, settings.shooting_window):
        if len(out) >= settings.shooting_fits:
            break
        out.setdefault(id(form), form)
    return list(out.values())


def not_excluded(forms: Sequence[ScreenedForm], window: float) -> list[ScreenedForm]:
    """The screened forms with terms that the screen cannot exclude: those whose screened BIC gain is within
    ``window`` (a share) of the best one's.  The screen is linearised at the uncorrected model's fit, where
    its gains are a small share of what the fits gain (300 000 against 55 million), and its order among
    forms that come close differs from the fits': on alumina_feeder's plant record the feeder's gain
    screened 6th, at 0.89 of the best, and the round named the alumina flow it left unfitted."""
    best = max((f.bic_gain for f in forms if f.features), default=0.0)
    return [f for f in forms if f.features and best > 0 and f.bic_gain >= (1.0 - window) * best]


def by_excess(forms: Sequence[ScreenedForm]) -> list[ScreenedForm]:
    """The screened forms by the channels' predicted excess (to 0.01 noise variances), then BIC gain."""
    return sorted(forms, key=lambda f: (round(f.excess, 2), -f.bic_gain))


def fit_by_shooting(
    model: CellModel, screen: ShotScreen, obs: Observations, settings: DiscoverySettings, share: slice
) -> list[ShotFit]:
    """The screen's candidates in ``share`` (job j of ``jobs``: ``slice(j, None, jobs)``), each fitted (step 3)."""
    few = shooting_cells(obs, settings.shooting_cells)
    fits = []
    for form in screen.candidates[share]:
        fit = shooting_fit(
            model,
            form.hypothesis,
            features=form.features,
            obs=few,
            segment_s=SEGMENT_S,
            iterations=settings.shooting_iterations,
        )
        fits.append(_assessed(model, form.hypothesis, features=form.features, few=few, fit=fit, settings=settings))
    return fits


def _assessed(model, hypothesis, features, few: Observations, fit: ShootingFit, settings) -> ShotFit:
    """The fit's covariance and channel tests, from its residuals and derivatives at the last stage."""
    segments = Segments(model, hypothesis, features, few, round(SEGMENT_S / few.dt))
    shot = Shooting.started(segments, fit.starts.reshape(-1, 8), fit.theta, CONTINUITY_STAGES[-1])
    shot.out, shot.ends, dout, dends = segments.integrate(shot.starts, fit.theta, "all")
    shot.res = shot.residuals(shot.out, shot.ends, shot.starts)
    schur, *_ = states_eliminated(*shot.normal_equations(*shot.jacobians(dout, dends), hold_theta=False))
    residual = np.where(segments.sampled & shot.active[:, None, None], segments.misfit(shot.out), np.nan)
    residual = residual.reshape(segments.n, segments.count, segments.steps, -1)
    tested = residual[:, 1:] if segments.count > 1 else residual  # as the fit's own chi2: after each first segment
    tests = innovation_tests(tested.reshape(segments.n, -1, len(few.channels)), few.channels, settings.z_threshold)
    tests = [replace(t, flagged=t.channel in fit.beyond_noise) for t in tests]
    return ShotFit(fit=fit, covariance=np.linalg.pinv(schur), tests=tests)


def decide_by_shooting(
    model: CellModel, screen: ShotScreen, fits: Sequence[ShotFit], obs: Observations, settings: DiscoverySettings
) -> SparseRound:
    """Rank the fits (``fits`` in the screen's candidates' order) and decide the round (step 4); ``obs``
    with each cell's first state searched under ``model`` where the screen searched it (:meth:`.Observations.with_start`:
    the corrected models' filters search theirs again, and one started from the nominal state instead is lost on
    a cell that the right correction follows at its noise)."""
    if obs.start is None and start_is_searched(obs.y, obs.channels):
        raise ValueError("decide_by_shooting: obs must carry the first states searched under the starting model")
    return replace(_decided(model, screen, fits, obs, settings), route="shooting", lost=screen.lost)


def _decided(model, screen: ShotScreen, fits: Sequence[ShotFit], obs: Observations, settings) -> SparseRound:
    tests, flagged = screen.tests, screen.flagged
    if not flagged:
        return SparseRound.quiet(model, tests, screen.left_out)
    few = shooting_cells(obs, settings.shooting_cells)
    base, cells = screen.base, f"cells 0-{settings.shooting_cells - 1}"
    penalty = float(np.log(int(np.isfinite(few.y).sum())))
    rng = np.random.default_rng(settings.seed)
    fitted, candidates = [], {}
    for form, shot in zip(screen.candidates, fits, strict=True):
        h, features, fit = form.hypothesis, list(form.features), shot.fit
        corrected = h.corrected(model, features, fit.theta)
        gain = base.cost - fit.cost - len(features) * penalty
        fitted.append(
            FittedForm(
                hypothesis=h,
                features=form.features,
                fit=fit,
                bic_gain=gain,
                cell_gains=base.cell_cost - fit.cell_cost,
                corrected=corrected,
            )
        )
        samples = rng.multivariate_normal(fit.theta, shot.covariance, size=settings.bootstrap, method="eigh")
        states = Segments(model, h, features, few, round(SEGMENT_S / few.dt)).path(fit.starts.reshape(-1, 8), fit.theta)
        candidates[id(fitted[-1])] = SparseCandidate(
            score=HypothesisScore(hypothesis=h, scale=1.0, walk=0.0, log_likelihood_gain=form.gain / 2), states=states, features=features, coefficients=fit.theta, samples=samples, inclusion=None, corrected=corrected,
            tests_after=shot.tests, log_likelihood=None, bic_gain=gain, rescued=0, explained=1.0 - fit.excess / base.excess if base.excess > 0 else 0.0,
        )  # fmt: skip
    x, u = base.starts.reshape(-1, 8), few.u[:, :: round(SEGMENT_S / few.dt)].reshape(-1, 5)
    ranking = ranked_fits(
        fitted,
        model,
        x=x,
        u=u,
        penalty=penalty,
        excess_before=base.excess,
        settings=settings,
    )
    paying = [candidates[id(f)] for f in ranking.order]
    order = paying + sorted((c for c in candidates.values() if c not in paying), key=lambda c: -c.bic_gain)

    def next_measured(chosen: Sequence[SparseCandidate]):
        return measure_next([(c.hypothesis.key, c.corrected, c.states) for c in chosen], few, MARGIN)

    if not ranking.order:
        verdict = (
            f"unexplained: channels {flagged} disagree beyond noise, but no closed form fitted on {cells} pays "
            "its terms in every cell"
        )
        return SparseRound.unexplained_round(model, tests, order, verdict, measure_next=next_measured(order[:3]))
    best = candidates[id(ranking.order[0])]
    share = filtered_share(best, obs, tests, flagged, settings)
    if not explains_enough(share, best.bic_gain, settings):
        verdict = (
            f"unexplained: channels {flagged} disagree beyond noise, but no closed form fitted on {cells} explains "
            f"them: the best, {best.hypothesis.key}, {removal(share, 'their excess on every cell')} by its filter, "
            f"less than {settings.min_explained:.0%}: not applied"
        )
        return SparseRound.unexplained_round(
            model, tests, order, verdict, measure_next=next_measured(to_separate(best, [], order))
        )
    chosen = candidates[id(ranking.equivalent[0])]
    equivalent = [candidates[id(f)] for f in ranking.equivalent[1:] + ranking.rivals]
    rivals = [candidates[id(f)] for f in ranking.rivals]
    effect = removal(chosen.explained, f"the channels' excess on {cells}")
    first = ranking.order[0]
    unfitted = [
        f.hypothesis
        for f in screen.unfitted(settings.shooting_window)
        if not alike(
            SimpleNamespace(
                hypothesis=f.hypothesis, corrected=f.hypothesis.corrected(model, list(f.features), f.theta)
            ),
            chosen,
            model,
            x,
            u,
        )  # fmt: skip
    ]
    chain = unfitted_chain(chosen.hypothesis, [f.hypothesis for f in screen.candidates], model, x, u)
    if chain:
        log.info("%s: the parts of its chain %s were not fitted", chosen.hypothesis.key, [h.key for h in chain])
    unfitted += [h for h in chain if h not in unfitted]
    told = screen_told(screen, settings)
    decision = ranking.decision(unfitted=bool(unfitted) or told is not None)
    elsewhere = held_elsewhere(model, chosen, obs, settings) if decision is not Decision.UNEXPLAINED else None
    if elsewhere is not None and elsewhere <= 0:
        verdict = (
            f"unexplained: the best correction on {cells}, {chosen.hypothesis.key}, does not hold on the other "
            f"cells (its BIC gain there: {elsewhere:.0f}), so it fits those cells, not what is missing from all; "
            "not applied"
        )
        recommended = next_measured(to_separate(chosen, [], order))
        return SparseRound.unexplained_round(model, tests, order, verdict, measure_next=recommended)
    left = ", ".join(f"{c} at {v:.3g}" for c, v in first.fit.beyond_noise.items())
    if decision is Decision.UNEXPLAINED:
        applied = chosen.explained >= settings.min_explained
        verdict = (
            f"unexplained: the best correction, {chosen.hypothesis.key}, leaves {left} times the noise variance "
            f"on {cells}, so what is missing may be an explanation that did not fit here or more than one effect; "
            f"the correction {effect}" + ("" if applied else f", less than {settings.min_explained:.0%}: not applied")
        )
        recommended = next_measured(to_separate(chosen, [], order))
        return SparseRound.unexplained_round(
            model, tests, order, verdict, measure_next=recommended, chosen=chosen if applied else None
        )
    if decision is Decision.NOT_IDENTIFIABLE:
        recommended = next_measured(to_separate(chosen, rivals, order))
        keys = ", ".join(c.hypothesis.key for c in [chosen, *rivals])
        verdict = (
            f"not identifiable: {keys} fit the measured channels on {cells} within {MARGIN:g} of BIC gain"
            if rivals
            else f"not identifiable: {keys} is the best fit on {cells}"
        )
        if unfitted:
            verdict += (
                f", and the screen could not exclude {', '.join(h.key for h in unfitted)}, not fitted "
                f"(at most {settings.shooting_fits} fits)"
            )
        if told is not None:
            verdict += f", and {told}"
        verdict += separating(recommended)
        separated = recommended[0].channel if recommended else None
        return SparseRound(
            model=model, tests=tests, ranking=order, chosen=chosen, equivalent=equivalent, decision=decision, separated_by=separated, verdict=f"{verdict}; the correction {effect}",
            measure_next=recommended, not_fitted=unfitted,
        )  # fmt: skip
    name = _hypothesis(model, ranking.names[0])
    what = name.describe(model)
    if name != chosen.hypothesis:
        what += f" (fitted as {chosen.hypothesis.key}, the same physics)"
    others = [key for key in ranking.names[1:] if key != chosen.hypothesis.key]
    if others:
        what += f"; no measurement tells it from {', '.join(others)}, the same physics"
    if decision is Decision.FORM_INCOMPLETE:
        what += f" (form incomplete: its closed form leaves {left} times the noise variance on {cells})"
    return SparseRound(
        model=model, tests=tests, ranking=order, chosen=chosen, equivalent=equivalent, decision=decision, verdict=f"{what}; the correction {effect}",
        name=None if name == chosen.hypothesis else name,
    )  # fmt: skip


def screen_told(screen: ShotScreen, settings: DiscoverySettings) -> str | None:
    """Why the screen excluded no hypothesis, or None where it did: its best form gained less than
    ``settings.min_gain`` of BIC, so the forms it gave no terms (nothing above zero) were not told from the
    best, only not fitted.  Linearised at an uncorrected fit whose joins absorb much of an effect, it can
    find almost nothing: on a drawn regimes record it gave one form a term (a transfer from the alumina to
    the AlF3, 0.1 of BIC) and every other hypothesis none; the transfer, fitted alone, was named wrongly
    for the missing alumina flow."""
    best = max((f.bic_gain for f in screen.forms), default=0.0)
    if best >= settings.min_gain:
        return None
    unfitted = sum(1 for f in screen.forms if all(f is not c for c in screen.candidates))
    return (
        f"the screen excluded none of the hypotheses not fitted ({unfitted}): its best form gained {best:.3g} of "
        f"BIC, less than {settings.min_gain:g}"
    )


def filtered_share(
    candidate: SparseCandidate,
    obs: Observations,
    tests: Sequence[ChannelTest],
    flagged: Sequence[str],
    settings: DiscoverySettings,
) -> float:
    """The share of the ``flagged`` channels' excess on every cell (the uncorrected model's filter's
    ``tests``) that ``candidate``'s correction removes, by its own filter from the start it searches
    itself: the filter route's measure (``explained``), for the rule every route names by.  A shooting
    fit's own excess on the first cells does not stand in for it: near noise there already, a share of
    it says little (a wrong transfer removed 29 % of it, a right conductivity 26 %)."""
    after, _ = channel_tests(candidate.corrected, obs.searched_again(candidate.corrected), settings, backward=False)
    return explained_share(tests, after, flagged)


def held_elsewhere(
    model: CellModel, chosen: SparseCandidate, obs: Observations, settings: DiscoverySettings
) -> float | None:
    """The BIC gain of ``chosen``'s correction over ``model`` on the cells the round did not fit (each model's
    filter from the start it searches itself; :func:`gain_where_held`), None where there are none.
    An effect missing from the model is missing in every cell: a correction that the other cells' own
    measurements reject fits the first cells' record, not the effect (a cryolite flow seen through the
    voltage alone, fitted on two cells of 35 h as a ledge flow in the AlF3 feed, lost 3,400 of
    log-likelihood on the four others)."""
    rest = obs.subset(slice(settings.shooting_cells, None))
    if rest.y.shape[0] == 0:
        return None
    before, after = (
        channel_tests(m, rest.with_start(m), settings, backward=False)[1].log_likelihood
        for m in (model, chosen.corrected)
    )
    return gain_where_held(before, after, len(chosen.features), int(np.isfinite(rest.y).sum()))


def gain_where_held(before: np.ndarray, after: np.ndarray, terms: int, samples: int) -> float:
    """The BIC gain of a correction of ``terms`` terms from the cells' log-likelihoods ``before`` and
    ``after`` it (n,; -inf or NaN where a cell's filter was lost), on the cells both filters hold, with
    ``samples`` measurements in all; minus infinity where the correction loses more cells' filters than it
    brings back.  A filter lost on one cell is the estimator's failure as often as the model's: on a drawn
    plant record the right correction (the bubbles' coverage in the ledge temperature) lost one of ten
    cells, brought back three that the uncorrected filter lost, and gained 5 x 10^5 to 9 x 10^7 of
    log-likelihood on each of the six both hold."""
    held_before, held_after = np.isfinite(before), np.isfinite(after)
    if (held_before & ~held_after).sum() > (held_after & ~held_before).sum():
        return -np.inf
    both = held_before & held_after
    return float(2 * (after[both] - before[both]).sum() - terms * np.log(max(samples, 2)))


def _hypothesis(model: CellModel, key: str) -> Hypothesis:
    return next(h for h in candidate_hypotheses(model) if h.key == key)
