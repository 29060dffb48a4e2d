"""What to measure next: the measurements that would tell explanations apart, in noise stds, and the chance
that the added record names one."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from scipy.stats import norm

from costa.discover.sparse.measure_next import (
    MULTIPLES,
    decides,
    measure_next,
    sampled_every,
    separating,
    to_separate,
)
from costa.discover.sparse.observations import Observations
from costa.physics import true_model

DAY = 8640  # steps of 10 s
SETTLE = 5760  # the 16 h a filter from a searched start settles in (the records here measure no fraction)
MARGIN = 10.0  # BIC


@pytest.fixture
def two_explanations():
    """Two cells over a day after they settle: the explanations' state histories differ only in the metal, by 30 kg."""
    model = true_model()
    x = np.tile(np.array([3000.0, 500.0, 1800.0, 14000.0, 10000.0, 970.0, 820.0, 580.0]), (2, SETTLE + DAY, 1))
    u = np.tile(np.array([18.0, 140000.0, 5.0, 5.0, 0.05]), (2, SETTLE + DAY, 1))
    other = x.copy()
    other[..., 4] += 30.0
    return [("first", model, x), ("second", model, other)], u


def _obs(u, channels=("U_cell",), every=(1,)):
    y = np.full((*u.shape[:2], len(channels)), np.nan)
    for c, stride in enumerate(every):
        y[:, ::stride, c] = 1.0
    return Observations(y=y, u=u, channels=tuple(channels), noise=np.ones(len(channels)), dt=10.0)


def test_the_measurement_that_separates_two_explanations_ranks_first(two_explanations):
    """A metal dip of 15 kg noise every 8 h sees 3 samples a cell of a 30 kg difference: sqrt(2 x 3 x 2^2)
    = 4.9 noise stds; daily, sqrt(2 x 1 x 2^2) = 2.8; channels on which they agree separate nothing."""
    explanations, u = two_explanations
    ranked = measure_next(explanations, _obs(u), MARGIN, top=10)
    assert [(r.channel, r.every_s) for r in ranked[:2]] == [("x5", 28800), ("x5", 86400)]
    assert ranked[0].separation == pytest.approx(np.sqrt(24)) and ranked[1].separation == pytest.approx(np.sqrt(8))
    assert all(r.separation == 0 for r in ranked[2:])
    assert "every 8 h" in ranked[0].describe() and (ranked[0].best, ranked[0].rival) == ("first", "second")
    # the chance of a name: the BIC lead of the truth over the other is normal, mean d^2 = 24, std 2 d
    assert ranked[0].decides == pytest.approx(norm.cdf((24 - MARGIN) / (2 * np.sqrt(24))))
    assert ranked[2].decides == 0.0


def test_a_channel_already_measured_as_often_is_not_recommended(two_explanations):
    explanations, u = two_explanations
    obs = _obs(u, ("U_cell", "x5"), (1, 2880))
    assert sampled_every(obs) == {"U_cell": 10.0, "x5": 28800.0}
    assert all(r.channel != "x5" for r in measure_next(explanations, obs, MARGIN, top=10))
    assert measure_next(explanations[:1], obs, MARGIN) == []
    pot = _obs(u, ("U_pot",), (1,))  # the pot voltage is the cell voltage plus constants
    assert all(r.channel != "U_cell" for r in measure_next(explanations, pot, MARGIN, top=10))


def test_where_no_instrument_is_left_to_add_more_of_the_same_record_is_recommended(two_explanations):
    """A record that dips the metal daily (15 kg noise) and may add nothing: one dip a cell after the filter
    settles sees the 30 kg difference, d^2 = 2 cells x 2^2 = 8 noise variances, short of the margin; twice the
    record gives 16, named with probability Phi((16 - 10) / (2 x 4)), the first multiple at a half or more.
    Explanations the measured channels cannot tell apart get the largest multiple and no chance; those this
    record already separates (a 1.5 kg dip) get nothing: what holds them level is not the margin."""
    explanations, u = two_explanations
    daily = Observations(y=_obs(u, ("x5",), (DAY,)).y, u=u, channels=("x5",), noise=np.array([15.0]), dt=10.0)
    (longer,) = measure_next(explanations, daily, MARGIN, available=())
    assert (longer.channel, longer.multiple, longer.explanations) == (None, 2, ("first", "second"))
    assert longer.separation == pytest.approx(4.0) and longer.decides == pytest.approx(norm.cdf(6 / 8))
    assert longer.describe().startswith("a record 2 times this one")
    same = [explanations[0], ("twin", *explanations[0][1:])]
    (never,) = measure_next(same, daily, MARGIN, available=())
    assert (never.multiple, never.decides, never.rival) == (MULTIPLES[-1], 0.0, "twin")
    exact = Observations(y=daily.y, u=u, channels=("x5",), noise=np.array([1.5]), dt=10.0)  # d^2 = 800
    assert measure_next(explanations, exact, MARGIN, available=()) == []  # held level by another rule, not the margin
    assert separating([longer]).startswith("; measuring a record 2 times this one") and separating([]) == ""
    assert separating([never]).startswith("; no measurement listed is likely to separate them (the likeliest: a record")


def test_one_cell_whose_filter_ran_away_does_not_decide():
    """An explanation whose smoothed wall temperature ran off to 1e6 degC on one cell of three does
    not make a shell thermocouple the best measurement: the median cell counts, and there the two
    agree on the wall."""
    model = true_model()
    x = np.tile(np.array([3000.0, 500.0, 1800.0, 14000.0, 10000.0, 970.0, 820.0, 580.0]), (3, SETTLE + DAY, 1))
    u = np.tile(np.array([18.0, 140000.0, 5.0, 5.0, 0.05]), (3, SETTLE + DAY, 1))
    other = x.copy()
    other[..., 4] += 30.0
    other[0, :, 7] = 1e6
    ranked = measure_next([("a", model, x), ("b", model, other)], _obs(u), MARGIN, top=10)
    assert ranked[0].channel == "x5" and ranked[0].separation == pytest.approx(np.sqrt(3 * 3 * 4))
    assert [r.separation for r in ranked if r.channel == "x8"] == [0.0]


def test_the_chance_of_a_name_over_every_explanation_standing():
    """Known values: far apart, a name is certain; at d^2 equal to the margin, a coin; an explanation the
    measurement cannot tell from another (d = 0) is never named, whichever of the two is the truth."""
    far = np.array([[0.0, 100.0], [100.0, 0.0]])
    assert decides(far, MARGIN) == pytest.approx(1.0)
    assert decides(np.sqrt(MARGIN) * (1 - np.eye(2)), MARGIN) == pytest.approx(0.5)
    twins = np.array([[0.0, 0.0, 100.0], [0.0, 0.0, 100.0], [100.0, 100.0, 0.0]])
    assert decides(twins, MARGIN) == pytest.approx(1 / 3)  # only the third, when it is the truth


def test_differences_while_the_filter_settles_and_dominated_instruments_count_for_nothing(two_explanations):
    """Explanations that differ only in their starts (the metal by 30 kg in the first 16 h, which each would fit
    again to new samples) are not separated by a metal dip; where they differ after it only at one instant, a dip
    every 8 h is no likelier to decide than a daily one, so only the daily one is listed."""
    (first, model, x), (second, _, other) = two_explanations[0]
    u = two_explanations[1]
    started = x.copy()
    started[:, :SETTLE, 4] += 30.0
    ranked = measure_next([(first, model, x), (second, model, started)], _obs(u), MARGIN, top=10)
    assert all(r.separation == 0 for r in ranked)
    once = x.copy()
    once[:, SETTLE, 4] += 60.0  # the first sample after the settling, which both instruments read
    dips = [
        r
        for r in measure_next([(first, model, x), (second, model, once)], _obs(u), MARGIN, top=10)
        if r.channel == "x5"
    ]
    assert [(r.every_s, r.separation) for r in dips] == [(86400, pytest.approx(np.sqrt(2 * 16)))]


def test_a_rival_without_a_closed_form_is_not_put_to_a_measurement():
    """A rival that screened ahead of the chosen correction may have no closed form (no corrected model):
    a measurement separates the fitted ones only, or the chosen one and the next best fitted."""
    chosen, fitted, next_best = (SimpleNamespace(corrected=object(), states=object()) for _ in range(3))
    unfitted = SimpleNamespace(corrected=None, states=None)
    ranking = [chosen, unfitted, fitted, next_best]
    assert to_separate(chosen, [unfitted, fitted], ranking) == [chosen, fitted]
    assert to_separate(chosen, [unfitted], ranking) == [chosen, fitted, next_best]
