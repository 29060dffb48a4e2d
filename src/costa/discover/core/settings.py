"""How discovery decides: the settings both routes read (the config sets some, the rest are fixed)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["DiscoverySettings"]


@dataclass(frozen=True, kw_only=True)
class DiscoverySettings:
    """How discovery decides; the same for every data set.  The config sets the window, the
    test thresholds, the term and gain limits, the rounds, the bootstrap and the seed
    (``discovery.*`` in the schema); the rest are fixed here."""

    window: int = 64  # steps per weak-form window
    window_scales: tuple[int, ...] = (1, 4, 16)  # longer windows, tried in turn when nothing disagrees
    z_threshold: float = 6.0  # an equation disagrees if its chi-square excess is this many standard errors ...
    min_excess: float = 0.1  # ... and at least this share of the noise variance
    max_terms: int = 8  # terms in a closed form
    min_gain: float = 10.0  # BIC gain a term (and a correction) must bring
    min_explained: float = 0.5  # share of the excess residual a correction must remove
    # sparse data: a correction leaving channels flagged is named ("form incomplete") only if it removes
    # this share of their excess and leaves the channels on average within form_excess noise variances of noise
    form_removed: float = 0.9
    form_excess: float = 0.5
    screen_keep: int = 8  # hypotheses that get a closed-form fit after screening (plus ties)
    min_screen: float = 0.05  # ... if a free delta along them explains at least this share
    refine_iterations: int = 8  # Gauss-Newton iterations
    bootstrap: int = 200  # resamples that select each candidate's terms and give their intervals
    blocks_per_trajectory: int = 4  # bootstrap groups: each trajectory cut into this many blocks
    max_rounds: int = 3
    noise_draws: int = 8  # Monte Carlo draws for the residual's noise scale
    equivalence: float = 10.0  # explanations within this BIC of the best are equally good (strong evidence)
    new_mechanism_margin: float = 0.05  # a new effect must gain this share more BIC than refining a named one
    screen_steps: int = (
        40_000  # partial measurements: every hypothesis is scored first on trajectories of this many steps in all
    )
    partial_candidates: int = 4  # ... the best so many get a closed form, fitted and scored on all trajectories
    # ... and after them every hypothesis the screen cannot exclude (its free delta gained about as much as the
    # chosen closed form), to partial_fits fits in all: a name stands only where every one was fitted and lost
    partial_fits: int = 12
    # ... random-walk steps of a hypothesis' delta, in noise stds per window (0: a constant delta)
    walks: tuple[float, ...] = (0.0, 0.3, 3.0)
    # a pot line's record (the first state searched): the first round decided by multiple shooting on the
    # first so many cells (0: by the filter, as on other records), fitting the best shooting_refine of
    # the screen by BIC gain and by the channels' predicted excess, each fit with the iterations
    # (of the states alone from the data, then of all together) of :func:`..sparse.shooting.fit.shooting_fit`
    shooting_cells: int = 0
    shooting_refine: int = 3
    # ... and every other whose screened BIC gain is within shooting_window of the best's (a share of it): the
    # screen cannot exclude those; at most shooting_fits fits in all, and a name stands only where every
    # hypothesis the screen cannot exclude was fitted (those not fitted are listed); 24 covered every
    # shipped and drawn plant record's window (at most 17 fits; 13-21 s a fit on the shipped records)
    shooting_window: float = 0.2
    shooting_fits: int = 24
    shooting_iterations: tuple[int, int] = (8, 30)
    seed: int | np.random.SeedSequence = 0  # the search's random stream (bootstrap, noise draws)
