"""The screen of every hypothesis' closed forms, linearised at the uncorrected model's shooting fit."""

from __future__ import annotations

import numpy as np
import pytest

from costa.discover.core.hypotheses import candidate_hypotheses
from costa.discover.core.library import LEDGE_AND_WALL, LINE_CURRENT
from costa.discover.core.naming import balance_moved, causes_through
from costa.discover.core.outcome import Decision
from costa.discover.sparse.shooting.fit import ShootingFit, states_eliminated
from costa.discover.sparse.shooting.screen import FittedForm, _forward, ranked_fits, screen_terms
from costa.physics import operating_points


def test_the_reduced_gradient_gives_what_the_coefficients_add_to_the_whole_least_squares_fit():
    """For a linear least-squares problem in each cell's states z_i and shared coefficients t,
    min sum_i |r_i + J_i z_i + K_i t|^2, hr' S^-1 hr is the fit's reduction with z and t free
    less its reduction with z alone, each from the projection onto the columns."""
    rng = np.random.default_rng(1)
    n, rows, size, terms = 3, 50, 12, 2
    j = rng.normal(size=(n, rows, size))
    k = rng.normal(size=(n, rows, terms))
    r = rng.normal(size=(n, rows))
    a, b = np.einsum("nri,nrj->nij", j, j), np.einsum("nri,nrp->nip", j, k)
    c, g, h = np.einsum("nrp,nrq->pq", k, k), np.einsum("nri,nr->ni", j, r), np.einsum("nrp,nr->p", k, r)
    schur, reduced, _, _ = states_eliminated(a, b, g, c, h)

    def reduction(columns: np.ndarray) -> float:
        fitted = columns @ np.linalg.lstsq(columns, r.reshape(-1), rcond=None)[0]
        return float(fitted @ fitted)

    whole = np.zeros((n * rows, n * size + terms))
    for i in range(n):
        whole[i * rows : (i + 1) * rows, i * size : (i + 1) * size] = j[i]
        whole[i * rows : (i + 1) * rows, n * size :] = k[i]
    added = reduction(whole) - reduction(whole[:, : n * size])
    np.testing.assert_allclose(reduced @ np.linalg.solve(schur, reduced), added, rtol=1e-9)


def test_forward_selection_finds_the_planted_terms_and_stops_where_a_term_no_longer_pays_its_bic():
    """Residuals r = -(2 k_1 - 3 k_4) + unit noise over 2000 samples and six candidate columns, two of
    them nearly copies of another: the terms chosen are the planted two, and no column of noise
    pays log(2000) of cost (the reduction of each added column is chi2(1): 1 on average)."""
    rng = np.random.default_rng(3)
    samples = 2000
    k = rng.normal(size=(samples, 6))
    k[:, 2] = k[:, 1] + 1e-6 * rng.normal(size=samples)  # a near copy of column 1
    k[:, 5] = k[:, 4] + 1e-6 * rng.normal(size=samples)  # and of column 4
    r = -(2 * k[:, 1] - 3 * k[:, 4]) + rng.normal(size=samples)
    chosen, reduction = _forward(k.T @ k, k.T @ r, np.log(samples), max_terms=4)
    assert sorted({c if c not in (2, 5) else c - 1 for c in chosen}) == [1, 4] and len(chosen) == 2
    expected = r @ k[:, chosen] @ np.linalg.solve(k[:, chosen].T @ k[:, chosen], k[:, chosen].T @ r)
    np.testing.assert_allclose(reduction, expected, rtol=1e-9)


def test_the_screen_follows_a_line_current_read_with_an_offset(model):
    """A current read 2 kA low reaches the cell as u2 + 2000: a relative gain 2000 / u2, which varies by
    a quarter over a running cell's 118-155 kA.  The screen's terms of the current's gain fit it to
    about 0.5 % of its mean (1/u2 is nearly linear there); without the current's own term (the
    composition and bath temperature, which do not follow it) they leave 8 %.  Every hypothesis is
    screened with the term."""
    hypotheses = candidate_hypotheses(model)
    gain = next(h for h in hypotheses if h.key == "input:u2")
    x, u = operating_points(np.random.default_rng(0), 2000)
    offset = 2000.0 / u[:, 1]

    def left(features) -> float:
        columns = gain.feature_values(model, features, x, u)
        fitted = columns @ np.linalg.lstsq(columns, offset, rcond=None)[0]
        return float(np.sqrt(np.mean((offset - fitted) ** 2)) / np.mean(offset))

    terms = screen_terms(gain)
    assert left(terms) < 0.01
    assert left([f for f in terms if f.name != LINE_CURRENT]) > 0.05
    assert all(LINE_CURRENT in [f.name for f in screen_terms(h)] for h in hypotheses)


@pytest.mark.parametrize("key", ["term:ledge_energy", "part:bubble_coverage"])
def test_the_screen_follows_a_rate_that_varies_with_the_ledge_and_wall_temperatures(model, key):
    """A flow that varies with the ledge's or the wall's temperature (a part: in proportion to itself) is
    fitted by the screen's terms to rounding; the bath's composition and temperature and the current,
    which vary independently of them over a running cell's range, leave over 80 % of it (the cells of a
    pot line differ in these temperatures)."""
    h = next(h for h in candidate_hypotheses(model) if h.key == key)
    x, u = operating_points(np.random.default_rng(0), 2000)
    own = model.quantities(x, u)[h.target] if h.kind == "part" else 1.0
    terms = screen_terms(h)
    bath_alone = [f for f in terms if not any(state in f.name for state in LEDGE_AND_WALL)]

    def left(features, rate) -> float:
        columns = h.feature_values(model, features, x, u)
        fitted = columns @ np.linalg.lstsq(columns, rate, rcond=None)[0]
        return float(np.sqrt(np.mean((rate - fitted) ** 2) / np.mean(rate**2)))

    for state in LEDGE_AND_WALL:
        rate = own * h.feature_values(model, [next(f for f in terms if f.name == state)], x, u)[:, 0]
        assert left(terms, rate) < 1e-6, state
        assert left(bath_alone, rate) > 0.8, state


#: a term's price in the tests below: log(samples)
PENALTY = 11.0
#: the uncorrected fit's excess: the flagged fits below remove too little of it to be an incomplete form
EXCESS = 1.0


def _fitted(
    model, hypotheses, key: str, coefficient: float, bic_gain: float, chi2: dict[str, float], cells=(0.5, 0.5)
) -> FittedForm:
    h = hypotheses[key]
    constant = next(f for f in h.features() if f.name == "1")
    fit = ShootingFit(
        theta=np.zeros(1),
        starts=np.zeros((1, 1, 8)),
        cost=0.0,
        cell_cost=np.zeros(2),
        chi2=chi2,
        samples=dict.fromkeys(chi2, 100),
        lost=0,
        iterations=1,
    )
    gains = np.array(cells) * (bic_gain + PENALTY)
    return FittedForm(
        hypothesis=h,
        features=(constant,),
        fit=fit,
        bic_gain=bic_gain,
        cell_gains=gains,
        corrected=h.corrected(model, [constant], [coefficient]),
    )


def test_fits_at_their_noise_are_ranked_by_bic_and_only_rivals_of_other_physics_leave_it_undecided(model):
    """Among fits whose every channel is within 3 sampling stds of its noise (100 samples: 1.42), the
    BIC decides, not the noise-level excess.  A constant AlF3 sink and the same change of the AlF3
    neutralisation are the same physics: named together.  A rival of other physics within 10 of the
    first's BIC gain leaves it undecided; a fit that pays nothing (BIC gain <= 0), or that one cell
    carries while another does not pay its share of the term's price, does not rank; where the best
    is flagged, the outcome is unexplained."""
    hypotheses = {h.key: h for h in candidate_hypotheses(model)}
    x, u = operating_points(np.random.default_rng(0), 20)
    sink = _fitted(model, hypotheses, "term:alf3_mass", -0.0026, 500.0, {"x6": 1.30, "c3": 0.9})
    same = _fitted(model, hypotheses, "part:alf3_neutralisation", 0.0026, 499.0, {"x6": 0.95, "c3": 0.8})
    other = _fitted(model, hypotheses, "property:alumina_impurity", 6.0, 495.0, {"x6": 1.0, "c3": 0.7})
    flagged = _fitted(model, hypotheses, "input:u3", 0.1, 9000.0, {"x6": 1.50, "c3": 0.9})
    free = _fitted(model, hypotheses, "input:u4", 0.1, 0.0, {"x6": 0.9, "c3": 0.9})

    ranking = ranked_fits([same, flagged, sink, free], model, x, u, PENALTY, EXCESS)
    assert ranking.order == [sink, same, flagged]
    assert ranking.decision() is Decision.NAMED and ranking.names == ["term:alf3_mass", "part:alf3_neutralisation"]
    assert ranking.decision(unfitted=True) is Decision.NOT_IDENTIFIABLE  # a hypothesis the screen left standing
    ranking = ranked_fits([same, other, sink], model, x, u, PENALTY, EXCESS)
    assert ranking.rivals == [other] and ranking.decision() is Decision.NOT_IDENTIFIABLE
    other = _fitted(model, hypotheses, "property:alumina_impurity", 6.0, 489.0, {"x6": 1.0, "c3": 0.7})
    ranking = ranked_fits([other, sink], model, x, u, PENALTY, EXCESS)
    assert ranking.decision() is Decision.NAMED and ranking.names == ["term:alf3_mass"]
    ranking = ranked_fits([flagged, free], model, x, u, PENALTY, EXCESS)
    assert ranking.order == [flagged] and ranking.decision() is Decision.UNEXPLAINED
    assert ranked_fits([free], model, x, u, PENALTY, EXCESS).decision() is Decision.UNEXPLAINED  # none pays
    lopsided = _fitted(model, hypotheses, "property:alumina_impurity", 6.0, 800.0, {"x6": 1.0}, cells=(0.995, 0.005))
    assert ranked_fits([lopsided, sink], model, x, u, PENALTY, EXCESS).order == [sink]
    even = _fitted(model, hypotheses, "property:alumina_impurity", 6.0, 800.0, {"x6": 1.0}, cells=(0.9, 0.1))
    assert ranked_fits([even, sink], model, x, u, PENALTY, EXCESS).order == [even, sink]


def test_a_fit_that_moves_one_balance_alone_is_named_as_the_flow_missing_from_it(model):
    """A constant 20.6 kW taken from the bath's heat of freezing changes the bath energy's rate and
    nothing else: no measurement tells it from a heat loss from the bath, the less specific claim,
    which is named first.  Not missing flows: a bath conductivity and a tapping gain (they change
    what the voltage and the crane scale read), a feed that delivers less (its alumina carries AlF3
    and cryolite with it: three balances) and an AlF3-to-cryolite transfer (two)."""
    hypotheses = {h.key: h for h in candidate_hypotheses(model)}
    x, u = operating_points(np.random.default_rng(0), 20)
    chi2 = {"x6": 1.0, "U_cell": 1.0}
    freezing = _fitted(model, hypotheses, "part:bath_freezing_heat", -20570.0, 5000.0, chi2)
    assert balance_moved(freezing.corrected, model, x, u) == "bath_energy"
    ranking = ranked_fits([freezing], model, x, u, PENALTY, EXCESS)
    assert ranking.decision() is Decision.NAMED and ranking.names == ["term:bath_energy", "part:bath_freezing_heat"]
    assert ranking.equivalent == [freezing]  # fitted as the heat of freezing
    for key, coefficient in (
        ("part:bath_conductivity", -0.1),
        ("input:u4", -0.1),
        ("input:u1", -0.08),
        ("transfer:alf3_mass->cryolite_mass", 0.001),
    ):
        assert balance_moved(_fitted(model, hypotheses, key, coefficient, 5000.0, chi2).corrected, model, x, u) is None


def test_a_property_that_moves_one_balance_alone_is_named_as_itself(model):
    """A bath heat capacity 10 % lower (relative correction +0.11 of the bath temperature's rate)
    changes the bath energy's rate and nothing else, as a missing flow would; but it is a property
    of the bath, not a flow, and is named as itself (unshipped bath_heat_capacity was named
    term:bath_energy before this rule)."""
    hypotheses = {h.key: h for h in candidate_hypotheses(model)}
    x, u = operating_points(np.random.default_rng(0), 20)
    capacity = _fitted(model, hypotheses, "property:bath_heat_capacity", 0.1124, 5000.0, {"x6": 1.0, "U_cell": 1.0})
    assert balance_moved(capacity.corrected, model, x, u) == "bath_energy"
    ranking = ranked_fits([capacity], model, x, u, PENALTY, EXCESS)
    assert ranking.decision() is Decision.NAMED and ranking.names == ["property:bath_heat_capacity"]


def test_a_voltage_fit_is_not_named_for_the_parts_that_act_on_the_cell_only_through_the_voltage(model):
    """U = g5 + u2 u5 / (2620 g2), with the bubble voltage g5 = 3.8168e-6 g3 g4 u2 / (g2 (1 - g3)), and
    nothing else reads g2, g3, g4 or g5: every correction of the voltage is, point by point, one of the
    bath conductivity, the bubbles' coverage or thickness, or their voltage (which turns across the
    coverage's pole at 2.06 % alumina).  Which of them is missing only their own fits tell, so a fit of
    the voltage names the voltage (the round fits the others too, and leaves it undecided where one was
    not fitted).  The liquidus temperature (the freezing rate and the ledge's heat flows read it) acts
    through no single part; the electric power u2 U has no such cause, since a sensor reads U itself."""
    hypotheses = {h.key: h for h in candidate_hypotheses(model)}
    x, u = operating_points(np.random.default_rng(0), 20)
    causes = ["bath_conductivity", "bubble_coverage", "bubble_thickness", "bubble_voltage"]
    assert causes_through("cell_voltage", model, x, u) == causes
    low = x.copy()  # alumina from 0.5 % to 12 %: across the bubble coverage's pole at 2.06 %
    low[:, 1] = np.linspace(0.005, 0.12, len(x)) / (1 - np.linspace(0.005, 0.12, len(x))) * (x[:, 2] + x[:, 3])
    assert causes_through("cell_voltage", model, low, u) == causes
    assert causes_through("bubble_voltage", model, x, u) == ["bubble_coverage", "bubble_thickness"]
    for part in ("electric_power", "freezing_rate", "bath_ledge_heat", "liquidus_temperature", "bath_conductivity"):
        assert causes_through(part, model, x, u) == [], part
    voltage = _fitted(model, hypotheses, "part:cell_voltage", 0.05, 5000.0, {"x6": 1.0, "U_cell": 1.0})
    ranking = ranked_fits([voltage], model, x, u, PENALTY, EXCESS)
    assert ranking.decision() is Decision.NAMED and ranking.equivalent == [voltage]
    assert ranking.names == ["part:cell_voltage"]
    conductivity = _fitted(model, hypotheses, "part:bath_conductivity", -0.1, 5000.0, {"x6": 1.0, "U_cell": 1.0})
    ranking = ranked_fits([conductivity], model, x, u, PENALTY, EXCESS)
    assert ranking.decision() is Decision.NAMED and ranking.names == ["part:bath_conductivity"]


def test_a_fit_that_removes_nearly_all_the_excess_is_named_with_its_forms_small_error(model):
    """Where the uncorrected fit's excess is 20 noise variances, a fit leaving the voltage at 1.5 (a
    small form error that 34 000 samples flag) and the bath temperature at noise removes 97 % of it
    and is named, "form incomplete"; at 2.1 (the two channels 0.55 beyond noise on average, more than
    the 0.5 every route allows) it is unexplained."""
    hypotheses = {h.key: h for h in candidate_hypotheses(model)}
    x, u = operating_points(np.random.default_rng(0), 20)
    small = _fitted(model, hypotheses, "input:u3", 0.1, 900.0, {"x6": 1.0, "U_cell": 1.5})
    ranking = ranked_fits([small], model, x, u, PENALTY, 20.0)
    assert ranking.decision() is Decision.FORM_INCOMPLETE and ranking.names == ["input:u3", "term:alf3_mass"]
    large = _fitted(model, hypotheses, "input:u3", 0.1, 900.0, {"x6": 1.0, "U_cell": 2.1})
    assert ranked_fits([large], model, x, u, PENALTY, 20.0).decision() is Decision.UNEXPLAINED
    assert ranked_fits([small], model, x, u, PENALTY, 1.0).decision() is Decision.UNEXPLAINED
