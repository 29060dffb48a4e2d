"""The discovery loop: test the equations, rank explanations, fit a closed form, correct, repeat.

One round:

1. residuals of the current model in weak form, and a chi-square test per equation
   against the noise (:mod:`.weak_form`); nothing flagged -> stop, nothing invented;
2. every hypothesis (:mod:`..core.hypotheses`) is screened by how much of the residual
   a free delta(t) along its sensitivity explains; the promising ones get a sparse
   closed form from the term library (:mod:`..core.library`, :mod:`..core.regression`):
   the terms a bootstrap over blocks of trajectories of the forward selection picks in
   at least half the resamples, refined by Gauss-Newton on the exact residual (a wrong liquidus
   temperature enters the energy balances squared); a term whose 99 % interval from the
   same resamples covers zero is dropped and the rest refitted, so every kept term's
   reported interval excludes zero;
3. candidates are ranked by the BIC gain of their correction on the exact residual;
   among those within ``equivalence`` of the best (a difference the data cannot
   call strong) the cause is named before its consequences (a part before the parts
   computed from it), then the simplest (fewest terms, then an input before a flow
   before a part correction, then the most elementary part); the others are reported as
   equivalent explanations, the rest as runners-up.  Every hypothesis the screen cannot
   exclude (a free delta along it removes ``min_explained`` of the excess) is fitted; where one
   within ``equivalence`` is different physics (:func:`..core.naming.decide`, the rule of every
   route), nothing is named: the round is not identifiable, the best correction is applied and
   the rounds stop.  In later rounds an effect named
   before is refined rather than a new one introduced unless the new one gains clearly
   more (``new_mechanism_margin``): what is left after a first closed form is usually the
   curvature that form missed, and any flow into the same balance can mimic it;
4. the named correction must remove a material share of the excess and gain enough
   BIC; the corrected model goes into the next round.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ...physics import CellModel, CellVariables
from ...variables import STATES
from ..core.fitted_terms import KEEP_LEVEL, FittedTerms, weakest_term
from ..core.hypotheses import Hypothesis, candidate_hypotheses
from ..core.library import Feature, constant_inputs
from ..core.naming import conclude, decide, explains_enough, removal
from ..core.noise import estimate_noise
from ..core.outcome import Decision, Round
from ..core.regression import GramSystem, coefficient_samples, independent_columns, selected_in_half, solve_subset
from ..core.settings import DiscoverySettings
from .weak_form import EquationTest, WeakForm, equation_tests

__all__ = ["Candidate", "FullStateRound", "discover"]

#: the relative change a property or an input's gain may take in a window's estimate: beyond
#: it, it is not a correction
RELATIVE_RANGE = (-0.5, 1.0)
#: the kinds whose delta is a relative change
RELATIVE = ("property", "input")


@dataclass
class Candidate(FittedTerms):
    """A hypothesis with its fitted closed form."""

    hypothesis: Hypothesis
    features: list[Feature]
    coefficients: np.ndarray
    bic_gain: float = 0.0
    explained: float = 0.0
    chi2_after: dict[str, float] = field(default_factory=dict)
    corrected: CellModel | None = None
    inclusion: dict[str, float] = field(default_factory=dict)  # term -> share of resamples selecting it
    samples: np.ndarray | None = None  # (resamples, terms) bootstrap coefficients around the refined values


@dataclass(kw_only=True)
class FullStateRound(Round):
    """What one round found (or that it found nothing) on every state (:class:`..core.outcome.Round`):
    ``where``, the operating variables each flagged equation's residual correlates with most;
    ``window``: steps per weak-form window of its tests."""

    tests: list[EquationTest]
    ranking: list[Candidate]
    chosen: Candidate | None
    equivalent: list[Candidate]
    where: dict[str, list[tuple[str, float]]]
    window: int = 0

    @property
    def flagged(self) -> list[str]:
        return [t.state for t in self.tests if t.flagged]


def _groups(n: int, windows: int, blocks: int) -> np.ndarray:
    """Group label of each (trajectory, window): trajectories cut into ``blocks`` pieces."""
    per_block = max(1, int(np.ceil(windows / blocks)))
    return (np.arange(n)[:, None] * blocks + np.arange(windows)[None, :] // per_block).ravel()


class _Problem:
    """The data, the weak form and the noise scale shared by every fit of a round."""

    def __init__(self, x: np.ndarray, u: np.ndarray, form: WeakForm, scale: np.ndarray, settings: DiscoverySettings):
        self.x, self.u, self.form, self.scale = x, u, form, scale
        self.left_x, self.left_u = x[:, :-1], u[:, :-1]
        windows = form.windows(x.shape[1])
        self.groups = np.repeat(_groups(x.shape[0], windows, settings.blocks_per_trajectory), 8)

        self._rates: dict[int, tuple[CellModel, np.ndarray]] = {}

    def standardised_residual(self, model: CellModel) -> np.ndarray:
        return self.form.residual(model, self.x, self.u) / self.scale

    def sensitivity(self, hypothesis: Hypothesis, model: CellModel) -> np.ndarray:
        """The hypothesis' sensitivity at the left end of every step, reusing the model's rates."""
        if id(model) not in self._rates:
            if len(self._rates) > 64:
                self._rates.clear()
            with np.errstate(all="ignore"):
                self._rates[id(model)] = (model, model.rhs(self.left_x, self.left_u))
        return hypothesis.sensitivity(model, self.left_x, self.left_u, base=self._rates[id(model)][1])

    def design(
        self,
        hypothesis: Hypothesis,
        model: CellModel,
        features: Sequence[Feature],
        sensitivity: np.ndarray | None = None,
    ) -> np.ndarray:
        """d(standardised residual)/d(xi) (rows, P): minus the windowed sensitivity times each term.

        The terms are evaluated with ``model`` (a part's own value is its value there); the
        per-step sensitivity may be given (evaluated at a better linearisation point).
        """
        sensitivity = self.sensitivity(hypothesis, model) if sensitivity is None else sensitivity
        a = sensitivity.shape[1] // self.form.window
        cut = a * self.form.window
        blocks = []
        for start in range(0, sensitivity.shape[0], 8):  # trajectories in chunks: the terms are large
            chunk = slice(start, start + 8)
            theta = hypothesis.feature_values(model, features, self.left_x[chunk], self.left_u[chunk])
            s = sensitivity[chunk, :cut].reshape(-1, a, self.form.window, 8)
            t = theta[:, :cut].reshape(s.shape[0], a, self.form.window, -1)
            blocks.append(np.einsum("naws,nawp,w->nasp", s, t, self.form.weights(), optimize=True))
        design = np.concatenate(blocks) / self.scale[..., None]
        return np.nan_to_num(design.reshape(-1, design.shape[-1]), nan=0.0, posinf=0.0, neginf=0.0)

    def screen(self, hypothesis: Hypothesis, model: CellModel, z: np.ndarray, flagged: Sequence[int]) -> float:
        """Share of the flagged equations' excess residual that a free delta per window along
        this hypothesis' sensitivity removes, beyond what such a delta removes from noise alone
        (about one unit of chi-square per window it can move).  Equations that agree with the
        data count only against it: a delta that absorbs their noise (or a sub-threshold
        residual) explains nothing that was flagged."""
        sensitivity = np.nan_to_num(self.form.average(self.sensitivity(hypothesis, model)) / self.scale)
        numerator, denominator = (sensitivity * z).sum(-1), (sensitivity**2).sum(-1)
        delta = np.divide(numerator, denominator, out=np.zeros_like(numerator), where=denominator > 0)
        removed = (z**2 - (z - delta[..., None] * sensitivity) ** 2).reshape(-1, 8).sum(0)
        agreeing = np.ones(8, bool)
        agreeing[list(flagged)] = False
        removed = removed[~agreeing].sum() + min(removed[agreeing].sum(), 0.0)
        excess = sum(max(float((z[..., i] ** 2).sum()) - z[..., i].size, 0.0) for i in flagged)
        return (removed - (denominator > 0).sum()) / excess if excess > 0 else 0.0


def _chi2(z: np.ndarray) -> dict[str, float]:
    flat = z.reshape(-1, 8)
    return {name: float(np.mean(flat[:, i] ** 2)) for i, name in enumerate(STATES)}


def _measure(problem: _Problem, h: Hypothesis, model: CellModel, iterations: int):
    """Stage 1: the delta (n, A) each window needs along the hypothesis' sensitivity, its
    information (n, A) (inverse variance), and the model shifted by it.  A part may enter
    nonlinearly (g1 appears squared, a heat capacity divides), so the estimates are iterated,
    the sensitivity re-evaluated at the shifted model."""
    n, a = problem.x.shape[0], problem.form.windows(problem.x.shape[1])
    per_sample = np.zeros(problem.left_x.shape[:2])
    delta = np.zeros((n, a))
    shifted = model
    iterated = h.kind in ("part", *RELATIVE)  # a flow enters linearly: one step is exact
    for _ in range(iterations if iterated else 1):
        z = problem.standardised_residual(shifted)
        per_step = problem.sensitivity(h, shifted)
        sensitivity = np.nan_to_num(problem.form.average(per_step) / problem.scale)
        information = (sensitivity**2).sum(-1)
        step = np.divide(
            (sensitivity * np.nan_to_num(z)).sum(-1), information, out=np.zeros_like(information), where=information > 0
        )
        delta += step
        if h.kind in RELATIVE:  # a relative change; keep clear of the pole of a divided capacity
            delta = np.clip(delta, *RELATIVE_RANGE)
        per_sample[:, : a * problem.form.window] = np.repeat(delta, problem.form.window, axis=1)
        per_sample[:, a * problem.form.window :] = delta[:, -1:]
        shifted = h.shifted(model, per_sample)
        if np.abs(step).max() <= 1e-3 * (np.abs(delta).max() + 1e-12):
            break
    if iterated:  # a window whose estimate has not settled (or sits at a bound) says nothing reliable
        typical = np.median(np.abs(delta)) + 1e-12
        unsettled = np.abs(step) > 1e-2 * (np.abs(delta) + typical)
        if h.kind in RELATIVE:
            unsettled |= (delta <= RELATIVE_RANGE[0]) | (delta >= RELATIVE_RANGE[1])
        information = np.where(unsettled, 0.0, information)
    return delta, information, shifted, per_step


def _explain(problem: _Problem, h: Hypothesis, model: CellModel, measured, features: list[Feature]):
    """Stage 2's normal equations: each window's delta against the terms averaged the way the
    window sees them (weighted by the sensitivity within it), weighted by the information.

    Returns the Gram system and the indices of the terms kept: a term that duplicates an
    earlier one (a relative term of a constant part, say) or is zero everywhere is dropped.
    """
    delta, information, shifted, per_step = measured
    n, a = delta.shape
    design = problem.design(h, model, features, sensitivity=per_step).reshape(n, a, 8, -1)
    sensitivity = np.nan_to_num(problem.form.average(per_step) / problem.scale)
    projected = np.einsum("nas,nasp->nap", sensitivity, design) / np.where(information > 0, information, 1)[..., None]
    weight = np.sqrt(information)[..., None]
    rows = (projected * weight).reshape(-1, len(features))
    kept = independent_columns(rows)
    system = GramSystem.from_design(rows[:, kept], (delta * weight[..., 0]).ravel(), problem.groups[::8])
    return system, kept


#: halvings of a Gauss-Newton step that raised the residual before the refinement stops
HALVINGS = 8


def _gauss_newton(problem: _Problem, h: Hypothesis, model: CellModel, features: list[Feature], xi, iterations: int):
    """Stage 3: the selected terms' coefficients minimising the exact residual.  A step that raises
    the residual is halved until it lowers it (or the refinement stops there): a part that enters
    through a pole (the bubbles' coverage, in g3 / (1 - g3)) overshoots a full step, and a
    refinement that made the fit worse named the wrong part on dev seed drawn21.  Where the
    linearised estimate fits worse than no correction, the refinement starts from none."""
    xi = np.array(xi, dtype=float)
    corrected = h.corrected(model, features, xi)
    z = problem.standardised_residual(corrected)
    z_none = problem.standardised_residual(model)
    if not np.isfinite(z).all() or float((z**2).sum()) > float((z_none**2).sum()):
        xi, corrected, z = np.zeros_like(xi), h.corrected(model, features, np.zeros_like(xi)), z_none
    for _ in range(iterations if features else 0):
        if not np.isfinite(z).all():
            break
        step, *_ = np.linalg.lstsq(problem.design(h, corrected, features), z.ravel(), rcond=None)
        rss = float((z**2).sum())
        for _ in range(HALVINGS):
            trial = h.corrected(model, features, xi + step)
            z_trial = problem.standardised_residual(trial)
            if np.isfinite(z_trial).all() and float((z_trial**2).sum()) < rss:
                break
            step = step / 2
        else:
            break
        xi, corrected, z = xi + step, trial, z_trial
        if np.all(np.abs(step) <= 1e-5 * (np.abs(xi) + 1e-12)):
            break
    return xi


def _fit(problem: _Problem, h: Hypothesis, model: CellModel, settings: DiscoverySettings, seed, rich: bool = False):
    """Measure delta per window (stage 1), select a closed form (stage 2) and refine it (stage 3),
    with one bootstrap over blocks of trajectories for both what is kept and what is reported.

    The terms forward selection picks in at least half the resamples are candidates; while any
    kept term's :data:`KEEP_LEVEL` interval covers zero, the one most often on the other side
    of zero is dropped and the rest refitted.  The coefficients are refined on the exact
    residual (stage 3) and the intervals re-centred on them, and checked again.  Every
    hypothesis of a round resamples with the same ``seed``, so that equivalent hypotheses (the
    same regression) get the same answer."""
    rng = np.random.default_rng(seed)
    library = h.features(rich)
    system, kept = _explain(problem, h, model, _measure(problem, h, model, settings.refine_iterations), library)
    weights, inclusion, terms = selected_in_half(
        system, settings.bootstrap, rng, max_terms=settings.max_terms, min_gain=settings.min_gain
    )
    G, b, _, _ = system.total()
    refined = None
    while True:
        centre = solve_subset(G, b, terms)
        spread = coefficient_samples(system, terms, weights) - centre  # resampled around the full-data fit
        weakest = weakest_term(spread + (centre if refined is None else refined), KEEP_LEVEL)
        if weakest is not None:
            terms.pop(weakest)
            refined = None
        elif refined is None:
            refined = _gauss_newton(problem, h, model=model, features=[library[kept[i]] for i in terms], xi=centre,
                                    iterations=settings.refine_iterations)  # fmt: skip
        else:
            break
    names = [library[i].name for i in kept]
    candidate = Candidate(
        hypothesis=h, features=[library[kept[i]] for i in terms], coefficients=refined,
        inclusion={n: float(p) for n, p in zip(names, inclusion, strict=True) if p > 0}, samples=spread + refined,
    )  # fmt: skip
    return candidate


def _score(
    problem: _Problem, candidate: Candidate, model: CellModel, z0: np.ndarray, flagged: Sequence[int]
) -> Candidate:
    """The exact residual of the corrected model: BIC gain and the share of the excess it removes."""
    h, features, xi = candidate.hypothesis, candidate.features, candidate.coefficients
    corrected = h.corrected(model, features, xi) if features else model
    z = problem.standardised_residual(corrected)
    rows, rss0 = z0.size, float((z0**2).sum())
    rss = float((z**2).sum()) if np.isfinite(z).all() else np.inf
    gain = rows * np.log(rss0 / rss) - len(features) * np.log(rows) if np.isfinite(rss) else -np.inf
    before, after = _chi2(z0), _chi2(z) if np.isfinite(rss) else dict.fromkeys(STATES, np.inf)
    excess_before = sum(max(before[STATES[i]] - 1, 0) for i in flagged)
    excess_after = sum(max(after[STATES[i]] - 1, 0) for i in flagged)
    explained = 1 - excess_after / excess_before if excess_before > 0 else 0.0
    return replace(candidate, bic_gain=float(gain), explained=float(explained), chi2_after=after, corrected=corrected)


def _where(
    problem: _Problem, model: CellModel, z: np.ndarray, flagged: Sequence[int]
) -> dict[str, list[tuple[str, float]]]:
    """For each flagged equation, the operating variables its residual correlates with most."""
    from scipy.stats import spearmanr  # here: scipy.stats takes 1.3-1.8 s to import, in every discovery job

    v = CellVariables(problem.left_x, problem.left_u)
    with np.errstate(all="ignore"):
        q = model.quantities(problem.left_x, problem.left_u)
    variables = {
        "c2 (Al2O3 fraction)": v.c2, "c3 (AlF3 fraction)": v.c3, "x6 (bath temperature)": v.x6,
        "x7 (ledge temperature)": v.x7, "x8 (wall temperature)": v.x8, "x1 (ledge mass)": v.x1,
        "u2 (line current)": v.u2, "u5 (anode-cathode distance)": v.u5,
        "superheat x6 - g1": v.x6 - q["liquidus_temperature"],
    }  # fmt: skip
    means = {name: problem.form.average(values[..., None])[..., 0].ravel() for name, values in variables.items()}
    # an input held constant (a pot line's current) correlates with nothing
    means = {name: values for name, values in means.items() if np.ptp(values) > 0}
    where = {}
    for i in flagged:
        residual = z[..., i].ravel()
        correlations = [(name, float(spearmanr(values, residual).statistic)) for name, values in means.items()]
        where[STATES[i]] = sorted(correlations, key=lambda item: -abs(item[1]))[:4]
    return where


def discover_round(
    model: CellModel, problem: _Problem, *, settings: DiscoverySettings, rng: np.random.Generator,
    rich: bool = False, named: Sequence[str] = (),
) -> FullStateRound:  # fmt: skip
    """One round on the current model (see the module docstring); ``rich``: the larger term
    library; ``named``: the keys of the hypotheses earlier rounds named."""
    window = problem.form.window
    z0 = problem.standardised_residual(model)
    tests = equation_tests(z0 * problem.scale, problem.scale, settings.z_threshold, settings.min_excess)
    flagged = [i for i, t in enumerate(tests) if t.flagged]

    def nothing_named(verdict: str, where=None, ranking=()) -> FullStateRound:
        """A round that corrects nothing: nothing disagrees, or nothing explains what does."""
        return FullStateRound(
            model=model, tests=tests, where=where or {}, ranking=list(ranking), chosen=None, equivalent=[],
            verdict=verdict, decision=Decision.UNEXPLAINED if flagged else Decision.QUIET, rich=rich,
            window=window,
        )  # fmt: skip

    if not flagged:
        return nothing_named("no equation disagrees with the data beyond noise")
    hypotheses = candidate_hypotheses(model, constant_inputs(problem.left_u))
    screened = sorted(((problem.screen(h, model, z0, flagged), h) for h in hypotheses), key=lambda item: -item[0])
    # the best few (hypotheses with the same sensitivity tie exactly: ties kept together), and every one
    # the screen cannot exclude: whose free delta removes what a name must (a name stands only where
    # they were all fitted; the line current's gain read at first as one of 13 bath heat flows on dev
    # seed drawn9, and was not among the best 8)
    cut = screened[min(settings.screen_keep, len(screened)) - 1][0] - 1e-3
    keep = [h for share, h in screened if share >= max(min(cut, settings.min_explained), settings.min_screen)]
    if not keep:
        verdict = (
            f"unexplained: equations {[STATES[i] for i in flagged]} disagree beyond noise, but no hypothesis "
            f"could remove {settings.min_screen:.0%} of the excess residual even with a free value in every window"
        )
        return nothing_named(verdict, where=_where(problem, model, z0, flagged))
    seed = rng.integers(2**63)
    ranking = [
        _score(problem, _fit(problem, h, model=model, settings=settings, seed=seed, rich=rich), model, z0, flagged)
        for h in keep
    ]
    ranking.sort(key=lambda c: -c.bic_gain)
    best = ranking[0].bic_gain
    good = [
        c
        for c in ranking
        if c.features
        and (
            c.bic_gain >= best - settings.equivalence
            or (c.hypothesis.key in named and c.bic_gain >= (1 - settings.new_mechanism_margin) * best)
        )
    ]
    where = _where(problem, model, z0, flagged)
    if not good or not explains_enough(good[0].explained, good[0].bic_gain, settings):
        top = ranking[0]
        verdict = (
            f"unexplained: equations {[STATES[i] for i in flagged]} disagree beyond noise, but no candidate "
            f"explains it: the best, {top.hypothesis.key}, {removal(top.explained, 'the excess residual')}"
        )
        return nothing_named(verdict, where=where, ranking=ranking)
    x, u = problem.left_x[:, ::16], problem.left_u[:, ::16]
    chosen, equivalent, rivals = decide(good, named, model, x, u)
    effect = removal(chosen.explained, "the excess residual")
    decision = conclude(left=False, tolerated=False, undecided=bool(rivals))
    what = chosen.hypothesis.describe(model)
    if decision is Decision.NOT_IDENTIFIABLE:
        keys = ", ".join(c.hypothesis.key for c in [chosen, *rivals])
        what = (
            f"not identifiable: {keys} explain the equations equally well (within {settings.equivalence:g} of BIC "
            f"gain), and they are different physics; the best fit, {chosen.hypothesis.key}, is applied"
        )
    return FullStateRound(
        model=model, tests=tests, where=where, ranking=ranking, chosen=chosen, equivalent=equivalent,
        verdict=f"{what}; the correction {effect}", decision=decision, rich=rich, window=window,
    )  # fmt: skip


def _first_disagreeing_scale(model, x, u, dt, noise, settings: DiscoverySettings, rng) -> _Problem:
    """The problem at the shortest window at which an equation disagrees (or the shortest).

    A small, slow effect hides in the noise of short windows but accumulates in long
    ones: the weak form's noise falls steeply with the window length while a constant
    bias in a rate does not.
    """
    problems = []
    for factor in settings.window_scales:
        form = WeakForm(settings.window * factor, dt)
        if form.windows(x.shape[1]) < 4:
            break
        scale = form.noise_scale(model, x, u=u, noise=noise, rng=rng, draws=settings.noise_draws)
        problem = _Problem(x, u, form, scale, settings)
        problems.append(problem)
        residual = problem.standardised_residual(model) * scale
        if any(t.flagged for t in equation_tests(residual, scale, settings.z_threshold, settings.min_excess)):
            return problem
    return problems[0]


def discover(
    model: CellModel, x: np.ndarray, u: np.ndarray, dt: float, settings: DiscoverySettings
) -> tuple[list[FullStateRound], np.ndarray]:
    """Rounds of discovery until no equation disagrees, nothing explains it, a round cannot name what
    explains it (its best correction applied, as on sparse data), or ``max_rounds``.

    Returns the rounds and the estimated measurement noise (8,).
    """
    rng = np.random.default_rng(settings.seed)
    noise = estimate_noise(x)
    rounds: list[FullStateRound] = []
    current = model
    rich = False
    for _ in range(settings.max_rounds):
        problem = _first_disagreeing_scale(current, x, u=u, dt=dt, noise=noise, settings=settings, rng=rng)
        named = [r.chosen.hypothesis.key for r in rounds if r.chosen is not None]
        found = discover_round(current, problem, settings=settings, rng=rng, rich=rich, named=named)
        rounds.append(found)
        if found.named is None:  # a later round would build on an unnamed cause
            break
        current = found.chosen.corrected
        # a closed form that leaves its own equations disagreeing: try richer forms next
        rich = any(found.chosen.chi2_after[s] - 1 > settings.min_excess for s in found.flagged)
    return rounds, noise
