"""Every hypothesis' closed forms scored at once, linearised at the uncorrected model's shooting fit.

The uncorrected model's segment starts are fitted first (:mod:`.fit`, no hypothesis), with
its channels' derivatives in those starts.  Each hypothesis then adds its screen terms
(:func:`screen_terms`), each a finite-difference row per segment integrated from those starts.  With the states' derivatives shared, the
Gauss-Newton step in the states and one hypothesis' coefficients together predicts how much
of the cost its closed form removes: the states' step is eliminated (a Schur complement
S, hr), and the reduction is hr' S^-1 hr, the score test of adding those terms.  The terms
are chosen per hypothesis by forward selection on these normal equations, each paying
log(samples) (BIC), and each channel's mean squared residual after the predicted step is
kept: the per-channel tests a ranking reads, where the summed cost is dominated by the
channel sampled most (the voltage's 17 000 samples a cell against six of the metal).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from ....physics import CellModel
from ...core.hypotheses import Hypothesis, candidate_hypotheses
from ...core.library import FIRST_ORDER, FLOW_INPUTS, LEDGE_AND_WALL, LINE_CURRENT, Feature
from ...core.naming import balance_moved, conclude, decide, naming_order, small_form_error
from ...core.outcome import Decision
from ...core.settings import DiscoverySettings
from ..observations import Observations
from ..observed import PRIOR_STD
from .fit import CONTINUITY_STAGES, Segments, Shooting, ShootingFit, channel_excess, shooting_fit, states_eliminated

__all__ = [
    "FittedForm",
    "Ranking",
    "ScreenedForm",
    "ranked_fits",
    "screen_forms",
    "screen_terms",
]

#: a coefficient's finite-difference step moves the state it moves most by this share of its
#: prior std over an hour: far above rounding, far below where the response bends
PROBE = 1e-3
#: how much more BIC gain the first fit needs than every rival to be told apart from them: 10, the
#: "very strong" evidence of Kass and Raftery (1995) on twice the log Bayes factor
MARGIN = 10.0
#: a term whose pivot, given the terms already chosen, is below this share of its own
#: information adds nothing new (it is, to rounding, a combination of those)
COLLINEAR = 1e-8


@dataclass(frozen=True)
class ScreenedForm:
    """A hypothesis' closed form from the screen: ``features`` chosen, ``theta`` their coefficients
    after the predicted step, ``gain`` the predicted cost decrease (twice the log-likelihood gain)
    and ``bic_gain`` that less log(samples) a term; ``chi2`` each channel's predicted mean squared
    residual in noise variances."""

    hypothesis: Hypothesis
    features: tuple[Feature, ...]
    theta: np.ndarray
    gain: float
    bic_gain: float
    chi2: dict[str, float]

    @property
    def excess(self) -> float:
        """The channels' predicted variance beyond noise (:func:`.fit.channel_excess`)."""
        return channel_excess(self.chi2)


def screen_terms(hypothesis: Hypothesis) -> list[Feature]:
    """The terms a hypothesis is screened with: a constant, the bath's composition and temperature
    (:data:`...core.library.FIRST_ORDER`), the line current and the ledge's and wall's temperatures
    (:data:`...core.library.LEDGE_AND_WALL`), linear; for a part also its own value, alone and times each
    of those but the current; and the feed and tapping flows where the hypothesis may read them.  The
    current varies by a quarter on a pot line's record: without its term a line current read with an offset
    (a gain of offset / u2) screened 5th, behind the voltage chain's parts, and was not fitted (dev plant
    seed drawn9; with it, named).  The ledge's and wall's temperatures differ between a line's cells:
    without them a coverage of the bubbles in x7 went unexplained (dev drawn21: the best form added 23 %
    to the flagged excess on every cell); with them it is named.  The masses x1 and m are left out: they
    drift slowly over a record, a ramp in time that lets the voltage's parts follow any drift on two
    cells (dev drawn2 lost its name with them at 8 fits; at 24 it kept it, but no dev verdict moved
    and the screen took a fifth longer)."""
    library = {f.name: f for f in hypothesis.features()}
    names = [*FIRST_ORDER, LINE_CURRENT, *LEDGE_AND_WALL, *FLOW_INPUTS]
    if hypothesis.kind == "part":
        names += ["own"] + [f"own*{name}" for name in (*FIRST_ORDER[1:], *LEDGE_AND_WALL)]
    return [library[name] for name in names if name in library]


def _steps(model: CellModel, hypothesis: Hypothesis, features: Sequence[Feature], x: np.ndarray, u: np.ndarray):
    """Each term's finite-difference step (P,) (:data:`PROBE`), from the states x (N, 8) and inputs u (N, 5)
    (the segments' first states and inputs).  A term that is zero there (a dose or tap, a few steps an
    hour) gets a unit step: its correction is linear in the coefficient, so any step above rounding serves."""
    with np.errstate(all="ignore"):
        rates = (
            hypothesis.sensitivity(model, x, u)[:, None, :]
            * hypothesis.feature_values(model, features, x, u)[..., None]
        )
    hourly = np.sqrt(np.nanmean(np.nan_to_num(rates * 3600.0 / PRIOR_STD) ** 2, axis=0)).max(-1)  # (P,)
    return np.divide(PROBE, hourly, out=np.ones(len(features)), where=hourly > 0)


def _forward(schur: np.ndarray, reduced: np.ndarray, penalty: float, max_terms: int) -> tuple[list[int], float]:
    """Terms chosen one at a time, each the one that adds most to hr' S^-1 hr, while it adds more
    than ``penalty``: (chosen, the reduction)."""
    chosen: list[int] = []
    best = 0.0
    while len(chosen) < max_terms:
        trials = {}
        for j in range(len(reduced)):
            if j in chosen or schur[j, j] <= 0:
                continue
            sub = [*chosen, j]
            block = schur[np.ix_(sub, sub)]
            pivot = schur[j, j] - (
                schur[j, chosen] @ np.linalg.solve(block[:-1, :-1], schur[chosen, j]) if chosen else 0
            )
            if pivot > COLLINEAR * schur[j, j]:
                trials[j] = float(reduced[sub] @ np.linalg.solve(block, reduced[sub]))
        if not trials:
            break
        j = max(trials, key=trials.get)
        if trials[j] - best < penalty:
            break
        chosen.append(j)
        best = trials[j]
    return chosen, best


def screen_forms(
    model: CellModel,
    hypotheses: Sequence[Hypothesis],
    obs: Observations,
    segment_s: float = 3600.0,
    iterations: tuple[int, int] = (8, 30),
    max_terms: int = 3,
) -> tuple[ShootingFit, list[ScreenedForm]]:
    """The model's shooting fit at the first continuity stage (:func:`.fit.shooting_fit`), and each
    hypothesis' closed form (at most ``max_terms`` of its :func:`screen_terms`) with its predicted gain
    and channels, linearised at that fit, best BIC gain first.  At the first stage: linearised at the
    last (the filter's continuity), where the uncorrected model is far from the data, the prediction
    overshot, and the right hypothesis ranked lower on 4 of 5 plant records (alumina_feeder 22nd by
    BIC gain against 6th)."""
    loose = CONTINUITY_STAGES[:1]
    fitted = shooting_fit(model, None, features=[], obs=obs, segment_s=segment_s, iterations=iterations, stages=loose)
    base, _ = Shooting.placed(
        model,
        None,
        features=[],
        obs=obs,
        segment_s=segment_s,
        iterations=0,
        starts=fitted.starts,
        theta=None,
        looseness=loose[0],
    )
    base.out, base.ends, base.res, base.cost = base.evaluate(base.starts, np.zeros(0))
    *_, states_out, states_ends = base.segments.integrate(base.starts, np.zeros(0), "all")
    seg = base.segments
    rows = base.starts
    u0 = seg.u[:, 0]
    samples = int(seg.sampled[base.active].sum())
    penalty = float(np.log(samples))
    forms = []
    for h in hypotheses:
        features = screen_terms(h)
        step = _steps(model, h, features, rows, u0)
        own = Segments(model, h, features=features, obs=obs, steps=seg.steps, step=step, derivatives=False)
        *_, dout, dends = own.integrate(rows, np.zeros(len(features)), "coefficients")
        shot = Shooting(own, rows)
        shot.active, shot.sigma, shot.res = base.active, base.sigma, base.res
        jm, je = shot.jacobians(np.concatenate([states_out, dout], 1), np.concatenate([states_ends, dends], 1))
        a, b, g, c, hv = shot.normal_equations(jm, je, hold_theta=False)
        # in units of each term's step
        schur, reduced, a_inv_b, a_inv_g = states_eliminated(a, b * step, g, c * np.outer(step, step), hv * step)
        chosen, gain = _forward(schur, reduced, penalty, max_terms)
        theta = -np.linalg.solve(schur[np.ix_(chosen, chosen)], reduced[chosen]) if chosen else np.zeros(0)
        states_step = -(a_inv_g + a_inv_b[..., chosen] @ theta).reshape(len(rows), 8)
        change = np.einsum("rikc,ri->rkc", jm[:, :8], states_step) + np.einsum(
            "rpkc,p->rkc", jm[:, [8 + k for k in chosen]], theta * step[chosen]
        )
        chi2, _ = base.channel_chi2(base.res[0] + change)
        forms.append(
            ScreenedForm(
                hypothesis=h, features=tuple(features[k] for k in chosen), theta=theta * step[chosen], gain=gain, bic_gain=gain - len(chosen) * penalty,
                chi2=chi2,
            )
        )  # fmt: skip
    return fitted, sorted(forms, key=lambda f: -f.bic_gain)


@dataclass(frozen=True)
class FittedForm:
    """A hypothesis' closed form fitted nonlinearly: ``bic_gain`` is the uncorrected fit's cost less
    this fit's, less log(samples) a term, and ``cell_gains`` (n,) each cell's cost decrease;
    ``corrected``: the model it corrects, so corrected."""

    hypothesis: Hypothesis
    features: tuple[Feature, ...]
    fit: ShootingFit
    bic_gain: float
    cell_gains: np.ndarray
    corrected: CellModel

    def small_form_error(self, excess_before: float, settings: DiscoverySettings) -> bool:
        """Whether the fit, not at its noise, leaves only a small error of its closed form
        (:func:`...core.naming.small_form_error`) against the uncorrected fit's excess ``excess_before``; what
        it leaves of each channel is its mean square beyond 1.  The voltage's 34 000 samples flag 1.03; on
        tapping_shortfall the true model's own fit left it at 1.06 through three continuity stages."""
        left = [max(v - 1.0, 0.0) for v in self.fit.chi2.values()]
        removed = 1.0 - self.fit.excess / excess_before if excess_before > 0 else 0.0
        return not self.fit.at_noise and small_form_error(removed, left, settings)


@dataclass(frozen=True)
class Ranking:
    """Fitted forms that pay their terms (positive BIC gain), best first (``order``); of those the first
    is not told apart from (within :data:`MARGIN` of its BIC gain, at noise or form incomplete), ``equivalent`` are the
    same physics as it (itself included), in the order they are named (:func:`...core.naming.naming_order`:
    the cause before its consequences, an input before a part), and ``rivals`` are not; ``names``: the
    keys named, in that order, with the flow missing from a balance that the first amounts to
    (:func:`...core.naming.balance_moved`), where no fit of it is among them."""

    order: list[FittedForm]
    equivalent: list[FittedForm]
    rivals: list[FittedForm]
    names: list[str] = field(default_factory=list)
    incomplete: bool = False  # the first's closed form leaves a small error (FittedForm.small_form_error)

    def decision(self, unfitted: bool = False) -> Decision:
        """What the fits decide (:func:`...core.naming.conclude`): unexplained where none pays its terms;
        ``unfitted``: a hypothesis the screen could not exclude, of other physics, was not fitted."""
        if not self.order:
            return Decision.UNEXPLAINED
        left = not self.order[0].fit.at_noise
        return conclude(left=left, tolerated=self.incomplete, undecided=bool(self.rivals) or unfitted)


def ranked_fits(
    fits: Sequence[FittedForm],
    model: CellModel,
    x: np.ndarray,
    u: np.ndarray,
    penalty: float,
    excess_before: float,
    settings: DiscoverySettings | None = None,
) -> Ranking:
    """The fits ranked and the first's rivals (:class:`Ranking`); physics compared at the states x
    (N, 8) and inputs u (N, 5) by :func:`...core.naming.decide`, the rule of every route.  A fit pays where every cell pays
    its share of the terms' price (``penalty``, log(samples), a term): an effect missing from the
    model is missing in every cell, and a gain that one cell alone carries fits that cell's own
    misplacement.  On tapping_shortfall's first two cells a wall heat capacity in c2 gained 1 and 226
    (its filter's likelihood: -22 and 812) where the right tapping gain gained 13 and 20.  Where a
    cell's record cannot show the effect, nothing is named.  Fits that leave every channel at
    its noise (:attr:`.fit.ShootingFit.at_noise`), or whose form is only incomplete against the
    uncorrected fit's excess ``excess_before`` (:meth:`FittedForm.small_form_error`), come first, by
    BIC gain: differences in the excess there are noise.  The rest follow by their excess (to 0.1
    noise variances), then BIC gain; where the first is one of them, nothing is told apart (the
    outcome is unexplained).  Where the first is a flow (:attr:`...core.hypotheses.Hypothesis.is_flow`)
    that changes one balance's rate alone, the flow missing from that balance is named with it, and first
    where :func:`...core.naming.naming_order` says so: on top_heat_loss a constant 20.6 kW taken from the bath's heat of freezing was the best fit
    of the bath's heat loss.  Not a property: a bath heat capacity 10 % lower changes the bath energy's
    rate alone, and is that property, not a missing flow (it was named wrongly so on bath_heat_capacity).
    A part of the voltage's chain (:func:`...core.naming.chain`) is not named for the others: a round
    fits each, and leaves the first undecided where one was not fitted (:mod:`.round`)."""
    settings = settings or DiscoverySettings()

    def good(f: FittedForm) -> bool:
        return f.fit.at_noise or f.small_form_error(excess_before, settings)

    order = sorted(
        [f for f in fits if f.bic_gain > 0 and f.cell_gains.min() > len(f.features) * penalty / len(f.cell_gains)],
        key=lambda f: (not good(f), -f.bic_gain if good(f) else round(f.fit.excess, 1), -f.bic_gain),
    )
    if not order or not good(order[0]):
        return Ranking(order=order, equivalent=order[:1], rivals=[], names=[f.hypothesis.key for f in order[:1]])
    first = order[0]
    close = [f for f in order if good(f) and first.bic_gain - f.bic_gain < MARGIN]
    chosen, others, rivals = decide(close, (), model, x, u)
    named = [chosen, *(f for f in others if all(f is not r for r in rivals))]
    keys = [f.hypothesis.key for f in named]
    balance = balance_moved(first.corrected, model, x, u) if first.hypothesis.is_flow else None
    also = [f"term:{balance}"] if balance is not None else []
    hypotheses = {h.key: h for h in candidate_hypotheses(model)}
    also = [key for key in also if key not in keys and key in hypotheses]
    if also:
        items = [*named, *(SimpleNamespace(hypothesis=hypotheses[key], features=first.features) for key in also)]
        reads = model.reads(x[:1], u[:1])
        keys = [f.hypothesis.key for f in naming_order(items, (), reads, terms=lambda f: len(f.features))]
    return Ranking(
        order=order,
        equivalent=named,
        rivals=rivals,
        names=keys,
        incomplete=not first.fit.at_noise,
    )
