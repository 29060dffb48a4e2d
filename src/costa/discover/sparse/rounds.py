"""What a round on partial measurements found, whichever route decided it: the shared result.

Both routes of the sparse search start from the uncorrected model's channel tests
(:func:`channel_tests`: its filter's innovations on every cell) and end in a
:class:`SparseRound` of :class:`SparseCandidate` s, which the findings, the summary table,
the report and "measure next" read alike: the filter route (:mod:`.filter`) scores each
hypothesis by the likelihood its random-walk delta gains, the shooting route
(:mod:`.shooting`) fits closed forms by multiple shooting.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from ...compiled import Smoothed
from ...physics import CellModel
from ..core.fitted_terms import FittedTerms
from ..core.hypotheses import Hypothesis
from ..core.library import Feature
from ..core.outcome import Decision, Round
from ..core.settings import DiscoverySettings
from .innovations import ChannelTest, LoneCell, LostCell, innovation_tests, lone_cell, lost_cells
from .measure_next import Recommendation
from .observations import Observations
from .observed import estimate_states

__all__ = [
    "BudgetComparison", "HypothesisScore", "SparseCandidate", "SparseRound", "best_first", "channel_tests",
    "likelihood_gains", "round_tests",
]  # fmt: skip


@dataclass(frozen=True)
class HypothesisScore:
    """A hypothesis' log-likelihood gain over the model without it, at its best random-walk step (on
    the shooting route: half the cost decrease the screen predicts for its closed form, at walk 0);
    ``rescued``: the trajectories its filter holds where the model's own diverged
    (:func:`likelihood_gains`); ``smoothing_walk``: the step its delta(t) is smoothed with for the
    closed form, its best step that lets delta move (a constant delta shows the regression nothing
    but a constant), or its best step where none of those holds."""

    hypothesis: Hypothesis
    scale: float
    walk: float
    log_likelihood_gain: float
    rescued: int = 0
    smoothing_walk: float | None = None

    @property
    def rank_key(self) -> tuple[int, float]:
        return self.rescued, self.log_likelihood_gain


def best_first(scores: Iterable[HypothesisScore]) -> list[HypothesisScore]:
    """``scores`` ranked by (trajectories rescued, gain), best first; ties keep their order."""
    return sorted(scores, key=lambda s: tuple(-k for k in s.rank_key))


@dataclass
class SparseCandidate(FittedTerms):
    """A hypothesis with its smoothed delta, the closed form fitted to it and the corrected model's
    score: ``bic_gain`` over the uncorrected model on the measured channels, ``explained`` the share
    of the flagged channels' excess it removes; ``placed``: the observations with the start the
    corrected model searches itself, from which it was tested (and a later round runs)."""

    score: HypothesisScore
    states: np.ndarray  # the states (n, K, 8) smoothed along its free delta
    features: list[Feature]
    coefficients: np.ndarray
    samples: np.ndarray  # bootstrap coefficients (resamples, terms)
    # each term's share of the bootstrap resamples that selected it (None: no bootstrap)
    inclusion: dict[str, float] | None
    corrected: CellModel | None = None
    tests_after: list[ChannelTest] = field(default_factory=list)
    log_likelihood: np.ndarray | None = None  # the corrected model's, per trajectory (n,)
    bic_gain: float = -np.inf
    rescued: int = 0  # trajectories whose filter the correction holds where the uncorrected model's diverged
    explained: float = 0.0
    placed: Observations | None = None

    @property
    def hypothesis(self) -> Hypothesis:
        return self.score.hypothesis


@dataclass(frozen=True)
class BudgetComparison:
    """The chosen correction against a rival of different physics with fewer terms, at the rival's
    term budget: ``chosen_gain`` is the BIC gain of the chosen closed form cut to the rival's
    ``terms`` strongest terms and refined again, ``rival_gain`` the rival's own; ``matched`` when
    the cut form does not beat the rival by the equivalence margin (its lead was bought by terms)."""

    rival: str
    terms: int
    chosen_gain: float
    rival_gain: float
    matched: bool


@dataclass(kw_only=True)
class SparseRound(Round):
    """What one round on partial measurements found (:class:`..core.outcome.Round`).

    ``separated_by``: the unmeasured channel that would tell the chosen correction from those as good;
    ``dispersion``: the best correction's remaining misfit (on the filter route), by which the
    equivalence window was widened; ``not_fitted``: hypotheses the screen could not exclude that were
    not fitted (of other physics than the chosen one): while they stand, nothing is named.
    """

    tests: list[ChannelTest]
    ranking: list[SparseCandidate]
    chosen: SparseCandidate | None
    equivalent: list[SparseCandidate]
    separated_by: str | None = None
    dispersion: float = 1.0
    at_budget: list[BudgetComparison] = field(default_factory=list)
    measure_next: list[Recommendation] = field(default_factory=list)
    route: str = "filter"  # how the round was decided: "filter" (:mod:`.filter`) or "shooting" (:mod:`.shooting`)
    not_fitted: list[Hypothesis] = field(default_factory=list)
    left_out: LoneCell | None = None  # the cell left out of the tests (:func:`round_tests`)
    lost: list[LostCell] = field(default_factory=list)  # the cells the tested model's filter lost (:func:`round_tests`)

    @classmethod
    def quiet(cls, model: CellModel, tests: list[ChannelTest], left_out: LoneCell | None = None) -> SparseRound:
        """A round in which no measured channel disagrees beyond noise (with ``left_out`` left out): nothing to explain."""
        verdict = "no measured channel disagrees beyond noise"
        if left_out is not None:
            verdict += (
                f" once {left_out.describe([t.channel for t in tests])} is left out: it alone disagrees, so the "
                "estimator lost it (a first state placed far off, a cell near the alumina pole) or something acts "
                "on that cell alone; physics missing from the model would show in the other cells too; look at "
                "that cell's record"
            )
        return cls(
            model=model, tests=tests, ranking=[], chosen=None, equivalent=[], decision=Decision.QUIET,
            verdict=verdict, left_out=left_out,
        )  # fmt: skip

    @classmethod
    def unexplained_round(
        cls, model: CellModel, tests: list[ChannelTest], ranking: list[SparseCandidate], verdict: str, *,
        measure_next: list[Recommendation], chosen: SparseCandidate | None = None, dispersion: float = 1.0,
    ) -> SparseRound:  # fmt: skip
        """A round in which channels disagree and nothing is named: ``chosen``, where given, is the best
        correction, applied without a name."""
        return cls(
            model=model, tests=tests, ranking=ranking, chosen=chosen, equivalent=[], decision=Decision.UNEXPLAINED,
            verdict=verdict, dispersion=dispersion, measure_next=measure_next,
        )  # fmt: skip

    @property
    def flagged(self) -> list[str]:
        return [t.channel for t in self.tests if t.flagged]

    @property
    def unexplained(self) -> list[str]:
        """The measured channels that still disagree beyond noise after the chosen correction."""
        return [t.channel for t in self.chosen.tests_after if t.flagged] if self.chosen is not None else []


def channel_tests(
    model: CellModel, obs: Observations, settings: DiscoverySettings, backward: bool = True
) -> tuple[list[ChannelTest], Smoothed]:
    """The model's innovation tests of each measured channel after the settling steps, from its filter
    (and smoother, where ``backward``) started at ``obs.start``."""
    smoothed = estimate_states(
        model, obs.y, u=obs.u, channels=obs.channels, noise_std=obs.noise, dt=obs.dt, backward=backward, start=obs.start
    )
    settled = smoothed.innovation[:, obs.settling_steps :]
    return innovation_tests(settled, obs.channels, settings.z_threshold, settings.min_excess), smoothed


def round_tests(
    model: CellModel, obs: Observations, settings: DiscoverySettings, backward: bool = True
) -> tuple[list[ChannelTest], Smoothed, LoneCell | None, list[LostCell]]:
    """The tests that open a round, whether ``model`` disagrees with the record at all: :func:`channel_tests`;
    where one cell alone carries every flag (:func:`.innovations.lone_cell`), the tests with it left out (none
    flagged) and that cell; and the cells whose filter was lost, from where (:func:`.innovations.lost_cells`:
    the tests hold none of their samples from there).  On a drawn plant record made by the starting model
    itself, one cell of twelve, its filter settling for 32 h from a ledge 535 kg off, flagged three channels.
    A correction's tests keep every cell: it is named only where it follows every one."""
    tests, smoothed = channel_tests(model, obs, settings, backward)
    settled = smoothed.innovation[:, obs.settling_steps :]
    lone = lone_cell(
        settled, obs.channels, tests, obs.dt, obs.settling_steps, settings.z_threshold, settings.min_excess
    )
    if lone is not None:
        rest = np.delete(settled, lone.cell, axis=0)
        tests = innovation_tests(rest, obs.channels, settings.z_threshold, settings.min_excess)
    return tests, smoothed, lone, lost_cells(smoothed.innovation, obs.y, obs.dt)


def likelihood_gains(rows: np.ndarray, base: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Log-likelihood gains (R,) of models with per-trajectory log-likelihoods ``rows`` (R, n) over a
    base model's (n,), and how many trajectories each holds where the base's filter diverged (R,).

    Where the base's filter diverged a difference from it means nothing: there each model is
    compared with the best of ``rows`` instead (so the gain still ranks the models), and the count
    records that it explains what the base cannot.  A model that loses a trajectory the reference
    holds gains minus infinity; a trajectory every model loses is left out.  Rank by (count, gain);
    where the base holds everywhere, the gain is the plain difference of total log-likelihoods."""
    rows = np.where(np.isfinite(rows), rows, -np.inf)
    held = np.isfinite(base)
    reference = np.where(held, base, rows.max(0, initial=-np.inf))
    informative = np.isfinite(reference)
    with np.errstate(invalid="ignore"):
        gains = (rows[:, informative] - reference[informative]).sum(-1)
    return gains, np.isfinite(rows[:, ~held]).sum(-1)
