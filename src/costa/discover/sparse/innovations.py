"""Whether a filter's innovations look like white unit noise, channel by channel.

The smoother (:meth:`...compiled.CompiledSystem.smooth`, an extended Kalman filter over the
compiled cell model) returns each measured channel's innovations standardised by their
predicted std: under a correct model they are white, zero-mean and of unit variance, which is
what :func:`innovation_tests` checks (the grey-box analogue of a residual test).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "ChannelTest", "LoneCell", "LostCell", "describe_lost", "explained_share", "innovation_excess", "innovation_tests",
    "lone_cell", "lost_cells",
]  # fmt: skip


@dataclass(frozen=True)
class ChannelTest:
    """Whether one measured channel's standardised innovations look like white unit noise.

    ``chi2_per_dof``: mean square (1 under a correct model); ``bias_z``: the mean in
    standard errors; ``whiteness_z``: the lag-1..``lags`` autocorrelation's Box-Pierce
    statistic as a z-score.  ``flagged``: any of the three beyond ``z_threshold``, and the
    excess material (chi-square above ``1 + min_excess`` or a mean beyond sqrt(min_excess)).
    """

    channel: str
    samples: int
    chi2_per_dof: float
    z: float
    bias: float
    bias_z: float
    whiteness_z: float
    flagged: bool


def _box_pierce_z(e: np.ndarray, lags: int) -> float:
    """Box-Pierce statistic of the (n, K) innovations with NaN gaps, pooled over trajectories, as a
    z-score of chi2: each lag's autocorrelation is weighted by its own number of pairs (its variance
    is 1/pairs under whiteness), so six samples a trajectory do not count as the pooled total."""
    statistic, used = 0.0, 0
    if np.isfinite(e).sum() <= lags + 1:
        return 0.0
    centred = e - np.nanmean(e)
    variance = np.nanmean(centred**2)
    for lag in range(1, lags + 1):
        products = centred[:, lag:] * centred[:, :-lag]
        pairs = np.isfinite(products).sum()
        if pairs:
            rho = np.nansum(products) / pairs / variance
            statistic, used = statistic + pairs * rho**2, used + 1
    return float((statistic - used) / np.sqrt(2 * used)) if used else 0.0


def innovation_tests(
    innovation: np.ndarray,
    channels: Sequence[str],
    z_threshold: float = 6.0,
    min_excess: float = 0.1,
    lags: int = 5,
) -> list[ChannelTest]:
    """Test each channel's standardised innovations (n, K, C): variance, bias and whiteness.

    Lags count measured samples of the channel, not steps: a channel sampled every
    hour is tested at lags of hours.
    """
    tests = []
    for c, name in enumerate(channels):
        e = innovation[..., c]
        present = np.isfinite(e)
        count = int(present.sum())
        if count == 0:
            continue
        packed = _packed(e)
        chi2 = float(np.nanmean(e**2))
        z = (chi2 - 1) / np.sqrt(2 / count)
        bias = float(np.nanmean(e))
        bias_z = bias * np.sqrt(count)
        white = _box_pierce_z(packed, lags)
        significant = max(z, abs(bias_z), white) > z_threshold
        material = chi2 - 1 > min_excess or bias**2 > min_excess
        tests.append(
            ChannelTest(
                channel=name,
                samples=count,
                chi2_per_dof=chi2,
                z=float(z),
                bias=bias,
                bias_z=float(bias_z),
                whiteness_z=white,
                flagged=bool(significant and material),
            )
        )
    return tests


#: a cell that alone carries a model's flags is taken for a lost one where its innovations in a flagged
#: channel exceed the noise variance by this much (twice it in all): on the dev plant records the lost cells'
#: were 2.4-41 times it, and a cell at 1.38 times it, just ahead of cells near 1.1, was only the largest
#: share of a small excess that every cell showed
LOST_EXCESS = 1.0


@dataclass(frozen=True)
class LoneCell:
    """A cell whose innovations alone carry every flag of a model's channel tests: with it left out, no
    channel disagrees beyond noise.  An effect missing from the model is missing in every cell; one cell
    alone says that the estimator lost it (a first state placed far off, a cell near the alumina pole) or
    that something acts on it alone.  ``chi2``: the mean square of each channel flagged with it, on this
    cell; ``hours``: the stretch (from the record's start) where it disagrees most: its largest run of
    squared innovations beyond 1 + :data:`LOST_EXCESS` noise variances, on the channel with the most excess
    on it."""

    cell: int
    chi2: dict[str, float]
    hours: tuple[float, float]

    def describe(self, channels: Sequence[str]) -> str:
        """'cell 11 (U_cell 3.25, c3 17.1 times the noise variance, most in hours 16-32)'."""
        values = ", ".join(f"{c} {self.chi2[c]:.3g}" for c in channels if c in self.chi2)
        return f"cell {self.cell} ({values} times the noise variance, most in hours {self.hours[0]:.0f}-{self.hours[1]:.0f})"


def lone_cell(
    innovation: np.ndarray, channels: Sequence[str], tests: Sequence[ChannelTest], step_s: float, first_step: int,
    z_threshold: float, min_excess: float,
) -> LoneCell | None:  # fmt: skip
    """The cell (of the innovations (n, K, C), ``tests`` their channel tests) that alone carries every
    flagged channel, its innovations beyond :data:`LOST_EXCESS` in one (:class:`LoneCell`), or None where no
    one cell does (or none is flagged, or there is one cell).  The cells are tried by their flagged
    channels' summed excess, largest first; ``step_s`` [s] and ``first_step`` (the record's step of
    ``innovation[:, 0]``) place the stretch in hours."""
    flagged = [channels.index(t.channel) for t in tests if t.flagged]
    n = innovation.shape[0]
    if not flagged or n < 2:
        return None
    excess = np.nansum(innovation[..., flagged] ** 2 - 1.0, axis=1)  # (n, flagged)
    for cell in np.argsort(-excess.sum(1)):
        e = innovation[cell][..., flagged]
        chi2 = {channels[c]: float(np.nanmean(e[:, i] ** 2)) for i, c in enumerate(flagged)}
        if max(chi2.values()) - 1.0 < LOST_EXCESS:
            continue
        rest = innovation_tests(np.delete(innovation, cell, axis=0), channels, z_threshold, min_excess)
        if not any(t.flagged for t in rest):
            worst = flagged[int(np.argmax(excess[cell]))]
            begin, end = _largest_run(innovation[cell, :, worst] ** 2 - 1.0 - LOST_EXCESS)
            hours = tuple(float((first_step + k) * step_s / 3600.0) for k in (begin, end))
            return LoneCell(cell=int(cell), chi2=chi2, hours=hours)
    return None


def _largest_run(values: np.ndarray) -> tuple[int, int]:
    """[first, last] step of the run of samples with the largest sum of ``values`` (K,) (NaN: not sampled)."""
    sampled = np.flatnonzero(np.isfinite(values))
    totals = np.concatenate([[0.0], np.cumsum(values[sampled])])
    end = int(np.argmax(totals[1:] - np.minimum.accumulate(totals)[:-1]))
    return int(sampled[int(np.argmin(totals[: end + 1]))]), int(sampled[end])


def innovation_excess(tests: Sequence[ChannelTest], channels: Sequence[str]) -> float:
    """The summed excess of the channels' innovations beyond white unit noise (variance and squared
    bias, in noise variances)."""
    by_name = {t.channel: t for t in tests}
    return sum(max(by_name[c].chi2_per_dof - 1, 0.0) + by_name[c].bias ** 2 for c in channels if c in by_name)


def explained_share(before: Sequence[ChannelTest], after: Sequence[ChannelTest], channels: Sequence[str]) -> float:
    """The share of the ``channels``' innovation excess under one model (``before``) that a corrected
    model's filter (``after``) removes: negative where it adds to it."""
    return 1 - innovation_excess(after, channels) / max(innovation_excess(before, channels), 1e-300)


def _packed(e: np.ndarray) -> np.ndarray:
    """Each trajectory's measured values side by side (n, max count), NaN-padded: lags in samples."""
    rows = [row[np.isfinite(row)] for row in e.reshape(-1, e.shape[-1])]
    width = max(len(r) for r in rows)
    packed = np.full((len(rows), width), np.nan)
    for i, r in enumerate(rows):
        packed[i, : len(r)] = r
    return packed


@dataclass(frozen=True)
class LostCell:
    """A cell whose filter was lost (its predicted covariance no longer one) from ``hour`` (from the record's
    start) on: its samples from there have no innovation, so the channel tests and the likelihoods leave them out."""

    cell: int
    hour: float


def lost_cells(innovation: np.ndarray, y: np.ndarray, step_s: float) -> list[LostCell]:
    """The cells of a filter's innovations (n, K, C) that have none at a sample of y (n, K, C) (the filter lost
    there), each from its first such step; ``step_s`` [s] a step."""
    lost = (np.isfinite(y) & ~np.isfinite(innovation)).any(-1)  # (n, K)
    return [
        LostCell(cell=int(i), hour=float(np.argmax(lost[i]) * step_s / 3600.0)) for i in np.flatnonzero(lost.any(1))
    ]


def describe_lost(lost: Sequence[LostCell]) -> str:
    """'cells 0 (from hour 0.0) and 4 (from hour 15.8)'."""
    each = [f"{c.cell} (from hour {c.hour:.1f})" for c in lost]
    listed = each[0] if len(each) == 1 else ", ".join(each[:-1]) + f" and {each[-1]}"
    return f"cell{'s' * (len(each) > 1)} {listed}"
