"""Multiple shooting: a closed form's coefficients and the cells' states fitted together.

The record of each cell is cut into segments of ``segment_s``; every segment starts from
a state of its own, integrated by RK4 over the segment, and meets the measured channels
where they are sampled.  Continuity between segments is a soft residual, so a model that
drifts far from the data in one segment does not carry the error into the next: the
objective has no cliffs where a filter would lose a cell.  Coefficients and every
segment's start are fitted by Levenberg-Marquardt; the sensitivities of every segment to
its start and the coefficients are the compiled model's tangents, carried beside each
segment's states (:meth:`...compiled.CompiledSystem.march_tangents`), and the normal
equations are solved by eliminating each cell's states (a Schur complement on the shared
coefficients).

The starts are placed twice.  First from the data alone: the sampled states interpolated to
each segment's first step, the Al2O3 fraction (which only the voltage shows, not
monotonically) the best of :data:`ALUMINA_GRID` over the segment, the rest the nominal cell;
the states are fitted first with the coefficients held, then everything together.  The data
alone do not place the unmeasured states (the ledge, the bath mass, the ledge's and the
wall's temperatures), and from them the true model's own fit stopped in a local minimum on 4
of 13 plant records.  So the fit is repeated from the smoothed states of the model so
corrected (:func:`filtered_starts`), and the better kept: from there the true model reaches
the noise on all 13 (at the first stage's continuity, below).  The data's placement serves
where the model is too far off for its filter to hold (the ablated bath conductivity's, on
conductivity_alf3, loses both cells).

All that at a continuity 100 times the filter's process noise, where the segments are free
enough to leave the data's placement; then again at 10, 3 and 1 times, each from the last
fit (:data:`CONTINUITY_STAGES`).  At the filter's own continuity the fit is its most probable
path, and the joins can no longer take up a slow missing flow that the closed form should.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_banded

from ....compiled import CompiledModel, Parameters
from ....physics import CellModel
from ...core.hypotheses import Hypothesis
from ...core.library import Feature
from ..observations import Observations
from ..observed import NOMINAL_STATE, PRIOR_STD, PROCESS_STD, estimate_states, searched_start

__all__ = [
    "ALUMINA_GRID",
    "Segments",
    "Shooting",
    "ShootingFit",
    "channel_excess",
    "damped_step",
    "states_eliminated",
    "filtered_starts",
    "shooting_fit",
]

#: Al2O3 mass fractions tried for each segment's first state
ALUMINA_GRID = (0.022, 0.026, 0.03, 0.035, 0.04, 0.05)
#: the bath mass [kg] a segment starts from where nothing measures it
BATH_KG = 14000.0
#: how far a segment's end may miss the next segment's start (1 std), in the filter's process noise
#: over the segment's steps (:data:`..observed.PROCESS_STD` times the square root of the steps), stage by
#: stage: each stage starts from the last one's fit.  The last is the filter's own, so the fit is
#: its most probable path and the cost ranks closed forms as its likelihood does.  Fitted at 100
#: alone, the joins absorbed top_heat_loss's missing 20 kW: the truth's closed form drifted from
#: -20 570 - 22 (x6 - 970) W to -2 589 + 168 (x6 - 970); at 1 it stays (-20 499 - 11 (x6 - 970)), but
#: from zero it stops at -1 828; through 10 it gets there.  From 10 straight to 1, the true model's own
#: fit on tapping_shortfall stopped at U_cell 1.06 noise variances after 30 iterations (cost 39 259;
#: 34 425 after 100): through 3 it reaches 0.98 (34 724) in 30.
CONTINUITY_STAGES = (100.0, 10.0, 3.0, 1.0)
#: the states are fitted first with the continuity this many times looser: far from the data, each
#: segment then finds its own cell before the segments are tied together
LOOSE = 10.0
#: how many sampling stds of its mean square a channel may lie above 1 and count as at its noise
NOISE_BAND = 3.0
#: a coefficient's absolute finite-difference step where the screen differences a hypothesis' terms
COEFFICIENT_STEP = 1e-4


@dataclass(frozen=True)
class ShootingFit:
    """The fitted coefficients (P,), segment starts (n, S, 8), the cost (the sum of squared
    residuals, each in noise stds; minus twice a log-likelihood up to a constant) and each cell's
    share of it (n,), each channel's mean squared residual over its samples after each cell's
    first segment (:meth:`Shooting.channel_chi2`) and its count of samples, the segments left out
    (lost already at the start) and the Levenberg-Marquardt iterations taken."""

    theta: np.ndarray
    starts: np.ndarray
    cost: float
    cell_cost: np.ndarray
    chi2: dict[str, float]
    samples: dict[str, int]
    lost: int
    iterations: int

    @property
    def excess(self) -> float:
        """The channels' variance beyond noise (:func:`channel_excess`)."""
        return channel_excess(self.chi2)

    @property
    def beyond_noise(self) -> dict[str, float]:
        """The channels whose mean square lies more than :data:`NOISE_BAND` sampling stds above 1 (the
        mean of n squared unit normals has std sqrt(2 / n)), with it."""
        return {c: v for c, v in self.chi2.items() if v > 1.0 + NOISE_BAND * np.sqrt(2.0 / max(self.samples[c], 1))}

    @property
    def at_noise(self) -> bool:
        """Whether no channel is :attr:`beyond_noise`: the closed form leaves nothing the noise does not
        explain, on any channel."""
        return not self.beyond_noise


def channel_excess(chi2: dict[str, float]) -> float:
    """The channels' mean squared residuals (noise variances) beyond 1, each channel counted once:
    the voltage's 34 000 samples weigh no more than the six metal heights."""
    return sum(max(v - 1.0, 0.0) for v in chi2.values())


class Segments:
    """The record as rows (cell-major, then segment) of ``steps`` samples each, and the model
    (corrected by ``hypothesis`` with ``features``, or as it is where None) integrated over them
    with its sensitivities (:class:`...compiled.CompiledModel`; ``derivatives`` False: the
    coefficients' alone, by finite differences); ``step`` (P,): each coefficient's
    finite-difference step."""

    def __init__(
        self,
        model: CellModel,
        hypothesis: Hypothesis | None,
        features: Sequence[Feature],
        obs: Observations,
        steps: int,
        step: np.ndarray | None = None,
        derivatives: bool = True,
    ):
        n, samples, channels = obs.y.shape
        self.obs, self.steps, self.n = obs, steps, n
        self.count = samples // steps
        used = self.count * steps
        self.y = obs.y[:, :used].reshape(n * self.count, steps, channels)
        self.u = obs.u[:, :used].reshape(n * self.count, steps, obs.u.shape[-1])
        self.sampled = np.isfinite(self.y)
        self.terms = len(features)
        self.step = np.full(self.terms, COEFFICIENT_STEP) if step is None else np.asarray(step, dtype=float)
        theta = Parameters(self.terms)
        self.model = model if hypothesis is None else hypothesis.parametrised(model, features, theta)
        self.kernel = CompiledModel(self.model, obs.dt, obs.channels, [theta], derivatives=derivatives)

    def integrate(self, starts: np.ndarray, theta: np.ndarray, directions: str = "none"):
        """Channels (R, steps, C) and end states (R, 8) of every row from ``starts`` (R, 8) under ``theta``
        (P,), and their derivatives (R, D, steps, C) and (R, D, 8): ``directions`` "all" in the scaled
        starts (in :data:`..observed.PRIOR_STD`) and theta, D = 8 + P, exact (the kernel's tangents);
        "coefficients" in theta alone, D = P, by finite differences of :attr:`step`; "none": no
        derivatives (None)."""
        rows = len(starts)
        theta = np.broadcast_to(np.asarray(theta, dtype=float), (rows, self.terms))
        if directions == "all":
            d = 8 + self.terms
            dx, dp = np.zeros((rows, 8, d)), np.zeros((rows, self.terms, d))
            dx[:, np.arange(8), np.arange(8)] = PRIOR_STD
            dp[:, np.arange(self.terms), 8 + np.arange(self.terms)] = 1.0
            out, dout, end, dend = self.kernel.march_tangents(starts, self.u, theta, dx, dp)
            return out, end, dout.transpose(0, 3, 1, 2), dend.transpose(0, 2, 1)
        if directions == "none":
            out, end = self.kernel.march(starts, self.u, theta)
            return out, end, None, None
        copies = 1 + self.terms  # each row, then each coefficient moved by its step
        moved = np.repeat(theta[:, None], copies, 1)
        moved[:, 1:] += np.diag(self.step)
        out, end = self.kernel.march(
            np.repeat(starts, copies, 0), np.repeat(self.u, copies, 0), moved.reshape(-1, self.terms)
        )
        out, end = out.reshape(rows, copies, self.steps, -1), end.reshape(rows, copies, 8)
        scale = 1 / self.step
        with np.errstate(all="ignore"):
            dout = (out[:, 1:] - out[:, :1]) * scale[None, :, None, None]
            dend = (end[:, 1:] - end[:, :1]) * scale[None, :, None]
        return out[:, 0], end[:, 0], dout, dend

    def path(self, starts: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """The states (n, S x steps, 8) at every step of every segment, each from its start (R, 8),
        under ``theta`` (P,)."""
        states, _ = self.kernel.march(starts, self.u, np.asarray(theta, dtype=float), record="states")
        return states.reshape(self.n, self.count * self.steps, 8)

    def misfit(self, out: np.ndarray) -> np.ndarray:
        """Measurement residuals (R, steps, C) in noise stds; 0 where not sampled."""
        return np.where(self.sampled, (out - np.nan_to_num(self.y)) / self.obs.noise, 0.0)


def filtered_starts(model: CellModel, obs: Observations, segment_s: float = 3600.0) -> np.ndarray:
    """Each segment's first state (n, S, 8): ``model``'s smoothed states (its filter from the first
    state it searches, :func:`..observed.searched_start`) at the first step of each ``segment_s`` [s];
    NaN where the filter lost the cell."""
    steps = max(1, round(segment_s / obs.dt))
    start = searched_start(model, obs.y, u=obs.u, channels=obs.channels, noise_std=obs.noise, dt=obs.dt)
    with np.errstate(all="ignore"):
        smoothed = estimate_states(
            model, obs.y, u=obs.u, channels=obs.channels, noise_std=obs.noise, dt=obs.dt, start=start
        ).mean
    return smoothed[:, : (obs.y.shape[1] // steps) * steps : steps]


def _data_starts(segments: Segments, theta: np.ndarray) -> np.ndarray:
    """Each segment's first state (R, 8) from the data alone (see the module's docstring)."""
    obs, n, count, steps = segments.obs, segments.n, segments.count, segments.steps
    at = np.arange(count) * steps
    start = np.tile(NOMINAL_STATE, (n, count, 1))

    def sampled(name: str, default: float) -> np.ndarray:
        """The channel interpolated to each segment's first step; ``default`` for a cell it never samples."""
        if name not in obs.channels:
            return np.full((n, count), default)
        values = obs.y[..., obs.channels.index(name)]
        k = np.arange(values.shape[1])
        return np.array(
            [
                np.interp(at, k[np.isfinite(v)], v[np.isfinite(v)]) if np.isfinite(v).any() else np.full(count, default)
                for v in values
            ]
        )

    start[..., 4], start[..., 5] = sampled("x5", NOMINAL_STATE[4]), sampled("x6", NOMINAL_STATE[5])
    alf3 = sampled("c3", 0.11)
    grid = np.repeat(start[None], len(ALUMINA_GRID), 0)
    for g, alumina in enumerate(ALUMINA_GRID):
        grid[g, ..., 1], grid[g, ..., 2] = alumina * BATH_KG, alf3 * BATH_KG
        grid[g, ..., 3] = (1 - alumina - alf3) * BATH_KG
    grid = grid.reshape(len(ALUMINA_GRID), n * count, 8)
    cost = np.full(grid.shape[:2], np.inf)
    for g, candidate in enumerate(grid):
        out, *_ = segments.integrate(candidate, theta)
        cost[g] = np.nan_to_num((segments.misfit(out) ** 2).sum((1, 2)), nan=np.inf)
    return grid[cost.argmin(0), np.arange(n * count)]


def shooting_fit(
    model: CellModel,
    hypothesis: Hypothesis | None,
    features: Sequence[Feature],
    obs: Observations,
    segment_s: float = 3600.0,
    iterations: tuple[int, int] = (8, 30),
    starts: np.ndarray | None = None,
    theta: np.ndarray | None = None,
    stages: Sequence[float] = CONTINUITY_STAGES,
) -> ShootingFit:
    """``model`` corrected by ``hypothesis`` (None: as it is) with the closed form sum_k theta_k f_k,
    fitted to ``obs`` by multiple shooting over segments of ``segment_s`` [s] from ``theta`` (P,)
    (default 0): ``iterations`` of the states alone from starts read from the data (theta held,
    the continuity :data:`LOOSE`), then of the states and theta together; then again from the
    corrected model's filtered states (:func:`filtered_starts`; the first fit's where the filter's
    are lost), the better fit kept (fewer segments lost, then the lower cost); all that at the
    continuity of the first of ``stages``, then each later stage from the last one's fit
    (:data:`CONTINUITY_STAGES`).  Given ``starts`` (n, S, 8) (another fit's), the ``stages`` from them."""

    def placed(start, theta, looseness, placing=0):
        return Shooting.placed(
            model, hypothesis, features=features, obs=obs, segment_s=segment_s, iterations=placing, starts=start,
            theta=theta, looseness=looseness,
        )  # fmt: skip

    def run(fit, theta):
        return fit.result(fit.run(theta, iterations[1], hold_theta=False))

    if starts is not None:
        best = run(*placed(starts, theta, stages[0]))
    else:
        best = run(*placed(None, theta, stages[0], iterations[0]))
        corrected = model if hypothesis is None else hypothesis.corrected(model, features, best.theta)
        again = filtered_starts(corrected, obs, segment_s).reshape(-1, 8)
        fit, theta = placed(again, best.theta, stages[0])
        if not fit.active.all():  # where the filter's states are lost, the first fit's starts serve
            again = np.where(fit.active[:, None], again, best.starts.reshape(-1, 8))
            fit, theta = placed(again, best.theta, stages[0])
        refit = run(fit, theta)
        best = refit if (refit.lost, refit.cost) < (best.lost, best.cost) else best
    for looseness in stages[1:]:
        best = run(*placed(best.starts, best.theta, looseness))
    return best


class Shooting:
    """Levenberg-Marquardt over the segment starts (scaled by :data:`PRIOR_STD`) and theta;
    ``starts`` (R, 8), ``theta`` (P,), and at them ``out``, ``ends`` (the channels and end states), ``res``
    (the residuals) and ``cost``."""

    def __init__(self, segments: Segments, starts: np.ndarray, looseness: float = CONTINUITY_STAGES[-1]):
        self.segments = segments
        self.sigma = looseness * PROCESS_STD * np.sqrt(segments.steps)
        self.prior_mean = starts.reshape(segments.n, segments.count, 8)[:, 0]
        self.active = np.ones(len(starts), dtype=bool)
        self.damping = 1e-3
        self.starts = starts
        self.iterations = 0

    @classmethod
    def placed(
        cls, model, hypothesis, features, obs, segment_s, iterations, starts, theta, looseness
    ) -> tuple[Shooting, np.ndarray]:
        """The fit of :func:`shooting_fit` after its first stage (or at ``starts`` (n, S, 8) where not
        None), and theta (0 if None), at the continuity ``looseness`` (:data:`CONTINUITY_STAGES`)."""
        segments = Segments(model, hypothesis, features, obs, max(1, round(segment_s / obs.dt)))
        theta = np.zeros(len(features)) if theta is None else np.asarray(theta, dtype=float)
        if starts is not None:
            return cls.started(segments, starts.reshape(-1, 8), theta, looseness), theta
        fit = cls.started(segments, _data_starts(segments, theta), theta, looseness)
        fit.sigma *= LOOSE
        fit.iterations = fit.run(theta, iterations, hold_theta=True)
        fit.sigma /= LOOSE
        return fit, theta

    @classmethod
    def started(cls, segments: Segments, starts: np.ndarray, theta: np.ndarray, looseness: float) -> Shooting:
        """A fit from ``starts`` (R, 8) (NaN: a segment left out), its lost segments left out."""
        lost = ~np.isfinite(starts).all(1)
        fit = cls(segments, np.where(lost[:, None], NOMINAL_STATE, starts), looseness)
        fit.leave_out_lost(fit.starts, theta)
        fit.active &= ~lost
        return fit

    def result(self, done: int) -> ShootingFit:
        """The fit as it stands, after ``done`` more iterations."""
        seg = self.segments
        starts = self.starts.reshape(seg.n, seg.count, 8)
        chi2, samples = self.channel_chi2(seg.misfit(self.out))
        lost = int((~self.active).sum())
        cells = self.cell_costs(self.res)
        return ShootingFit(
            theta=self.theta,
            starts=starts,
            cost=self.cost,
            cell_cost=cells,
            chi2=chi2,
            samples=samples,
            lost=lost,
            iterations=self.iterations + done,
        )

    def channel_chi2(self, residual: np.ndarray) -> tuple[dict[str, float], dict[str, int]]:
        """Each channel's mean squared ``residual`` (R, steps, C) over its samples, and their count,
        leaving out each cell's first segment where it has more: there only the prior places the unmeasured states
        (the ledge, its and the wall's temperatures), as the filter's tests leave out its settling
        (on alumina_feeder, one cell's first hour held 282 of the true model's 372 in the bath
        temperature)."""
        seg = self.segments
        tested = self.active.reshape(seg.n, seg.count).copy()
        tested[:, 0] &= seg.count == 1
        tested = tested.reshape(-1)
        sums = (residual[tested] ** 2).sum((0, 1))
        counts = seg.sampled[tested].sum((0, 1))
        chi2 = {c: float(v) for c, v in zip(seg.obs.channels, sums / np.maximum(counts, 1), strict=True)}
        return chi2, {c: int(k) for c, k in zip(seg.obs.channels, counts, strict=True)}

    def residuals(self, out, ends, starts):
        """Measurement (R, steps, C), continuity (n, S-1, 8) and first-start prior (n, 8) residuals."""
        n, count = self.segments.n, self.segments.count
        measured = self.segments.misfit(out)
        measured[~self.active] = 0.0
        linked = self.active.reshape(n, count)
        linked = linked[:, :-1] & linked[:, 1:]
        continuity = (ends.reshape(n, count, 8)[:, :-1] - starts.reshape(n, count, 8)[:, 1:]) / self.sigma
        continuity[~linked] = 0.0
        prior = (starts.reshape(n, count, 8)[:, 0] - self.prior_mean) / PRIOR_STD
        return measured, continuity, prior, linked

    def evaluate(self, starts, theta):
        """The channels and end states (:meth:`Segments.integrate`), the residuals and the cost at ``starts``, ``theta``."""
        out, ends, _, _ = self.segments.integrate(starts, theta)
        res = self.residuals(out, ends, starts)
        cost = float(self.cell_costs(res).sum())
        return out, ends, res, cost if np.isfinite(cost) else np.inf

    def cell_costs(self, res) -> np.ndarray:
        """Each cell's share (n,) of the cost at the residuals ``res`` (:meth:`residuals`)."""
        seg = self.segments
        measured, continuity, prior, _ = res
        return (
            (measured**2).sum((1, 2)).reshape(seg.n, seg.count).sum(1) + (continuity**2).sum((1, 2)) + (prior**2).sum(1)
        )

    def leave_out_lost(self, starts, theta):
        """Leave out the segments whose integration is lost already from their first state."""
        out, ends, _, _ = self.segments.integrate(starts, theta)
        self.active = np.isfinite(self.segments.misfit(out)).all((1, 2)) & np.isfinite(ends).all(1)

    def run(self, theta, iterations, hold_theta) -> int:
        """Up to ``iterations`` steps from :attr:`starts` and ``theta``; the steps taken."""
        starts = self.starts
        self.out, self.ends, self.res, self.cost = self.evaluate(starts, theta)
        done = 0
        for done in range(1, iterations + 1):
            *_, dout, dends = self.segments.integrate(starts, theta, "all")  # the derivatives where the step starts
            normal = self.normal_equations(*self.jacobians(dout, dends), hold_theta)
            while True:
                step_z, step_t = damped_step(*normal, self.damping)
                trial_z = starts + (step_z.reshape(-1, 8) * PRIOR_STD)
                trial_t = theta + step_t
                out, ends, trial_res, cost = self.evaluate(trial_z, trial_t)  # a step refused costs no derivatives
                if cost < self.cost:
                    improved = (self.cost - cost) / self.cost
                    starts, theta, self.out, self.ends, self.res, self.cost = (
                        trial_z,
                        trial_t,
                        out,
                        ends,
                        trial_res,
                        cost,
                    )
                    self.damping = max(self.damping / 10, 1e-7)
                    break
                self.damping *= 10
                if self.damping > 1e8:
                    self.starts, self.theta = starts, theta
                    return done
            if improved < 1e-7:
                break
        self.starts, self.theta = starts, theta
        return done

    def jacobians(self, dout, dends):
        """The measured residuals' derivatives jm (R, D, steps, C) and the segment ends' over the
        continuity std je (R, D, 8), from the channels' and end states' derivatives ``dout`` (R, D,
        steps, C) and ``dends`` (R, D, 8) (:meth:`Segments.integrate`); 0 where not sampled, left out
        or not finite."""
        seg = self.segments
        with np.errstate(all="ignore"):
            jm = dout / seg.obs.noise
            je = dends / self.sigma[None, None, :]
        kept = seg.sampled[:, None] & self.active[:, None, None, None] & np.isfinite(jm)
        return np.where(kept, jm, 0.0), np.where(np.isfinite(je), je, 0.0)

    def normal_equations(self, jm, je, hold_theta):
        """Per cell: the states' block A (n, S8, S8), the states-theta block B (n, S8, P), its
        gradient g (n, S8); and theta's C (P, P) and h (P,) (zero where theta is held), at the
        residuals :attr:`res` with the derivatives of :meth:`jacobians`."""
        seg = self.segments
        n, count, terms = seg.n, seg.count, jm.shape[1] - 8
        measured, continuity, prior, linked = self.res
        flat = jm.reshape(*jm.shape[:2], -1)
        block = (flat @ np.swapaxes(flat, 1, 2)).reshape(n, count, 8 + terms, 8 + terms)
        grad = (flat @ measured.reshape(len(flat), -1, 1)).reshape(n, count, 8 + terms)
        a = np.zeros((n, count, 8, count, 8))
        b = np.zeros((n, count, 8, terms))
        g = grad[..., :8].copy()
        c = block[..., 8:, 8:].sum((0, 1))
        h = grad[..., 8:].sum((0, 1))
        for s in range(count):
            a[:, s, :, s, :] += block[:, s, :8, :8]
            b[:, s] += block[:, s, :8, 8:]
        je = je.reshape(n, count, 8 + terms, 8)
        jump = PRIOR_STD / self.sigma  # d continuity / d (the next scaled start): -diag(jump)
        for s in range(count - 1):
            on = linked[:, s][:, None, None]
            phi, tht = je[:, s, :8] * on, je[:, s, 8:] * on  # (n, 8, 8): row = parameter, column = residual
            r = continuity[:, s]
            a[:, s, :, s, :] += phi @ np.swapaxes(phi, 1, 2)
            a[:, s, :, s + 1, :] -= phi * jump
            a[:, s + 1, :, s, :] -= np.swapaxes(phi * jump, 1, 2)
            a[:, s + 1, :, s + 1, :] += np.diag(jump**2) * on
            b[:, s] += phi @ np.swapaxes(tht, 1, 2)
            b[:, s + 1] -= np.swapaxes(tht, 1, 2) * jump[None, :, None]
            c += np.einsum("npk,nqk->pq", tht, tht)
            g[:, s] += np.einsum("npk,nk->np", phi, r)
            g[:, s + 1] -= r * jump
            h += np.einsum("npk,nk->p", tht, r)
        a[:, 0, :, 0, :] += np.eye(8)
        g[:, 0] += prior
        a, b, g = a.reshape(n, count * 8, count * 8), b.reshape(n, count * 8, terms), g.reshape(n, count * 8)
        if hold_theta:
            b, c, h = np.zeros_like(b), np.eye(terms), np.zeros(terms)
        return a, b, g, c, h


def states_eliminated(a, b, g, c, h):
    """The normal equations [[A_i, B_i], [B_i', C]] (A (n, S8, S8), B (n, S8, P), C (P, P)) with
    gradients g (n, S8), h (P,) reduced to the coefficients: the Schur complement
    S = C - sum_i B_i' A_i^-1 B_i, the reduced gradient hr = h - sum_i B_i' A_i^-1 g_i, and A^-1 B,
    A^-1 g.  The Gauss-Newton step in states and coefficients removes hr' S^-1 hr more of the cost
    than the states' step alone.  A state nothing informs (a segment left out) gets a unit diagonal.
    Each A_i is block tridiagonal (a segment's start is tied to the next one's): solved as a band."""
    diagonal = np.einsum("nii->ni", a)
    a = a + (diagonal == 0)[:, :, None] * np.eye(a.shape[1])
    solved = _banded_solve(a, np.concatenate([b, g[..., None]], axis=-1))
    a_inv_b, a_inv_g = solved[..., :-1], solved[..., -1]
    return c - np.einsum("nip,niq->pq", b, a_inv_b), h - np.einsum("nip,ni->p", b, a_inv_g), a_inv_b, a_inv_g


def _banded_solve(a: np.ndarray, rhs: np.ndarray, width: int = 15) -> np.ndarray:
    """a^-1 rhs for a (n, N, N) whose entries vanish beyond ``width`` off the diagonal (the states'
    normal matrix: 8 x 8 blocks on the diagonal and beside it) and rhs (n, N, m)."""
    size = a.shape[1]
    width = min(width, size - 1)
    out = np.empty_like(rhs)
    for i, matrix in enumerate(a):
        band = np.zeros((2 * width + 1, size))
        for k in range(-width, width + 1):
            band[width - k, max(k, 0) : size + min(k, 0)] = np.diagonal(matrix, k)
        out[i] = solve_banded((width, width), band, rhs[i])
    return out


def damped_step(a, b, g, c, h, damping):
    """The damped Gauss-Newton step (states (n, S8), theta (P,)): each cell's states eliminated."""
    # Marquardt's scaling; a parameter nothing informs (a tap's gain on a record without taps, a
    # segment left out) has a zero row and gradient: a unit diagonal keeps it where it is
    diagonal, shared = np.einsum("nii->ni", a), np.diag(c)
    a = a + (damping * diagonal)[:, :, None] * np.eye(a.shape[1])
    c = c + np.diag(damping * shared + (shared == 0))
    schur, reduced, a_inv_b, a_inv_g = states_eliminated(a, b, g, c, h)
    step_t = np.linalg.solve(schur, -reduced)
    step_z = -(a_inv_g + np.einsum("nip,p->ni", a_inv_b, step_t))
    return step_z.reshape(-1), step_t
