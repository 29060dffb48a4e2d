"""Sensor sets turn a simulated truth into what a plant logs; the estimator recovers what nobody measured."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from costa.discover.cases.shipped import add_noise
from costa.discover.cases.unshipped import find_case
from costa.discover.sparse.innovations import (
    LOST_EXCESS,
    ChannelTest,
    LostCell,
    describe_lost,
    explained_share,
    innovation_tests,
    lone_cell,
    lost_cells,
)
from costa.discover.sparse.observed import estimate_states
from costa.observe import observe
from costa.physics import ablated_model, true_model
from costa.sensors import AT_TAPS, CHANNELS, Sensor, SensorSet, measure, sensor_sets_from_config, tap_starts
from costa.simulate import simulate_set
from costa.variables import STATES


@pytest.fixture(scope="module")
def truth(settings):
    trajectories, _ = simulate_set(true_model(), dataclasses.replace(settings, steps=1200), 4, 11, 0, "sensors")
    return trajectories.x, trajectories.u


def test_sampling_intervals_noise_and_absent_channels(truth):
    x, u = truth
    sensors = SensorSet(
        "plant", (Sensor("U_cell", 10.0, 0.005), Sensor("x6", 3600.0, 1.5), Sensor("c3", 1800.0, 0.002))
    )
    table = measure(true_model(), x, u, 10.0, sensors, np.random.default_rng(0))
    assert set(STATES) & set(table.columns) == {"x6"} and {"u1", "u5", "time_s"} <= set(table.columns)
    x6 = table["x6"].to_numpy().reshape(4, -1)
    for row in x6:
        times = np.flatnonzero(np.isfinite(row))
        assert len(times) in (3, 4) and (np.diff(times) == 360).all()  # hourly: every 360 steps of 10 s
    phases = {int(np.flatnonzero(np.isfinite(row))[0]) for row in x6}
    assert len(phases) > 1  # hand samples at another minute in each cell
    voltage = table["U_cell"].to_numpy().reshape(4, -1)
    exact = observe(true_model(), x, u, ["U_cell"])[..., 0]
    assert np.std(voltage - exact) == pytest.approx(0.005, rel=0.05)
    assert np.isfinite(voltage).all()


def test_the_full_set_reproduces_noise_added_to_every_state(truth):
    x, u = truth
    level = 0.01
    full = SensorSet("full", tuple(Sensor(s, 10.0) for s in STATES))
    default = dict(zip(STATES, level * x.reshape(-1, 8).std(0), strict=True))
    table = measure(true_model(), x, u, 10.0, full, np.random.default_rng(5), default)
    expected = add_noise(x, level, np.random.default_rng(5))
    np.testing.assert_array_equal(table[list(STATES)].to_numpy().reshape(x.shape), expected)


def test_config_sets_and_unknown_channels():
    sets = sensor_sets_from_config({"p": {"hours": 48, "channels": {"U_cell": {"every_s": 10, "noise": 0.005}}}})
    assert sets["p"].channels == ("U_cell",) and sets["p"].steps(10.0, 5000) == 17280
    with pytest.raises(ValueError, match="unknown channel 'x9'"):
        Sensor("x9", 10.0, 1.0)
    assert CHANNELS[-5:] == ("U_cell", "U_pot", "c2", "c3", "m_tap")


def test_a_pot_line_logs_the_pot_voltage_of_4_2_volts(truth):
    """U_pot = U + E0 + R_ext u2: the bath and bubbles' 1.45 V plus the back EMF 1.8 V and the anodes',
    cathode's and bus bars' 0.95 V at 140 kA, the 4.2 V an industrial pot reads; logged with its noise."""
    x, u = truth
    sensors = SensorSet("pot line", (Sensor("U_pot", 10.0, 0.005),))
    table = measure(true_model(), x, u, 10.0, sensors, np.random.default_rng(3))
    pot = table["U_pot"].to_numpy().reshape(x.shape[:2])
    cell = observe(true_model(), x, u, ["U_cell"])[..., 0]
    assert np.std(pot - cell - (1.8 + 6.8e-6 * u[..., 1])) == pytest.approx(0.005, rel=0.05)
    near = np.abs(u[..., 1] - 140_000) < 2_000
    assert np.median(pot[near]) == pytest.approx(4.2, abs=0.1)


def test_a_pot_voltage_outside_its_plausible_range_is_left_empty(truth):
    """A plant's log holds no pot voltage outside 2.5-7 V (an anode effect, a logging error): the data
    contract refuses one, so a simulated record leaves such a sample empty and keeps the rest."""
    x, u = truth[0][:, :50].copy(), truth[1][:, :50].copy()
    u[:, 10:13, 1] = 1.2e6  # the external drop alone, 6.8e-6 V/A, puts these steps above 7 V
    table = measure(
        true_model(), x, u, 10.0, SensorSet("pot", (Sensor("U_pot", 10.0, 0.005),)), np.random.default_rng(0)
    )
    pot = table["U_pot"].to_numpy().reshape(x.shape[:2])
    assert np.isnan(pot[:, 10:13]).all()
    kept = np.delete(pot, [10, 11, 12], axis=1)
    assert np.isfinite(kept).all() and ((kept > 2.5) & (kept < 7.0)).all()


def test_the_pot_voltage_beyond_the_bath_is_a_measurement_not_physics(truth):
    """Another back EMF or external resistance shifts U_pot by exactly their change and no balance."""
    from costa.config import load_config
    from costa.physics import model_from_config

    x, u = truth[0][:, :50], truth[1][:, :50]
    cell = {"back_emf": 1.6, "external_resistance": 5e-6}
    other = model_from_config(load_config(overrides={"physics": {"cell": cell}})["physics"])[0]
    shift = observe(other, x, u, ["U_pot"]) - observe(true_model(), x, u, ["U_pot"])
    np.testing.assert_allclose(shift[..., 0], -0.2 - 1.8e-6 * u[..., 1], rtol=1e-9)
    np.testing.assert_array_equal(other.rhs(x, u), true_model().rhs(x, u))


def test_unmeasured_ledge_is_recovered_and_a_wrong_model_is_flagged(truth):
    """Partial sensors (no ledge mass, ledge temperature or masses): under the true model the
    smoother finds the unmeasured initial ledge within a few of its stds and no channel
    disagrees; under the ablated PBM (liquidus fixed) the bath temperature does."""
    x, u = truth
    x, u = x[:, :600], u[:, :600]
    channels = ("x5", "x6", "x8", "U_cell", "c2", "c3")
    noise = 0.01 * observe(true_model(), x, u, channels).reshape(-1, 6).std(0)
    sensors = SensorSet("partial", tuple(Sensor(c, 10.0, float(s)) for c, s in zip(channels, noise, strict=True)))
    table = measure(true_model(), x, u, 10.0, sensors, np.random.default_rng(2))
    y = table[list(channels)].to_numpy().reshape(*x.shape[:2], 6)
    right = estimate_states(true_model(), y, u, channels, noise, 10.0)
    error = np.abs(right.mean[:, 0] - x[:, 0]) / right.std[:, 0]
    assert np.median(error[:, [0, 6]]) < 3 and (np.abs(right.mean[:, 0, 0] - x[:, 0, 0]) < 100).all()
    assert not any(t.flagged for t in innovation_tests(right.innovation, channels))
    wrong = innovation_tests(estimate_states(ablated_model(), y, u, channels, noise, 10.0).innovation, channels)
    assert {t.channel for t in wrong if t.flagged} >= {"x6"}


def test_a_corrections_share_of_the_excess_counts_the_flagged_channels_variance_and_bias():
    """The share of the flagged channels' excess a correction removes (every route's ``explained``): the
    voltage's 2 noise variances and the bath temperature's 0.5 + a bias of 0.5 std (0.25) make 2.75; a
    correction leaving the voltage at 1.5 and the temperature unbiased below its noise removes 1 - 0.5 / 2.75,
    one that raises the voltage to 4 adds 1 / 2.75; a channel not flagged counts for nothing."""

    def tests(voltage: float, temperature: float, bias: float) -> list[ChannelTest]:
        values = {"U_cell": (voltage, 0.0), "x6": (temperature, bias), "c3": (5.0, 0.0)}
        return [ChannelTest(c, 100, chi2, 0.0, b, 0.0, 0.0, True) for c, (chi2, b) in values.items()]

    before, flagged = tests(3.0, 1.5, 0.5), ["U_cell", "x6"]
    assert explained_share(before, tests(1.5, 0.9, 0.0), flagged) == pytest.approx(1 - 0.5 / 2.75)
    assert explained_share(before, tests(4.0, 1.5, 0.5), flagged) == pytest.approx(-1 / 2.75)


@pytest.mark.parametrize(("scale", "off", "lone"), [(2.5, 1, 5), (2.5, 3, None), (1.9, 1, None)])
def test_a_flag_carried_by_one_lost_cell_names_that_cell_and_where(scale, off, lone):
    """White unit innovations on 6 cells (2 channels, 3,600 steps of 10 s); ``off`` cells (the last ones)
    have their first channel scaled by ``scale`` over hours 2-5.  One such cell at 2.5 (2.6 times the
    noise variance over the cell) alone carries the flag: with it left out none remains, and it is named
    with the hours of its excess (from a record whose first 600 steps were left out: hours 3.7-6.7).
    Where three carry it, no one cell does; one at 1.9 (1.8 times the noise variance) carries it too, but
    is not lost (:data:`LOST_EXCESS`)."""
    rng = np.random.default_rng(0)
    e = rng.standard_normal((6, 3600, 2))
    e[6 - off :, 720:1800, 0] *= scale
    tests = innovation_tests(e, ["U_cell", "x6"])
    assert [t.channel for t in tests if t.flagged] == ["U_cell"]
    found = lone_cell(e, ["U_cell", "x6"], tests, step_s=10.0, first_step=600, z_threshold=6.0, min_excess=0.1)
    if lone is None:
        assert found is None
        return
    assert found.cell == lone and found.chi2["U_cell"] == pytest.approx(2.6, abs=0.15)
    assert found.chi2["U_cell"] > 1 + LOST_EXCESS
    assert found.hours[0] == pytest.approx(3.67, abs=0.1) and found.hours[1] == pytest.approx(6.67, abs=0.1)
    assert not any(t.flagged for t in innovation_tests(np.delete(e, lone, axis=0), ["U_cell", "x6"]))
    assert lone_cell(e[:1], ["U_cell", "x6"], tests, 10.0, 0, 6.0, 0.1) is None  # one cell: nothing to leave out


def test_a_cell_whose_filter_is_lost_is_named_from_where_it_has_no_innovation(truth):
    """The filter of the true model on 4 cells' voltage (every 10 s) and hourly bath temperature follows
    every cell from the first states they were simulated from; started with cell 2's AlF3 at -500 kg
    (its liquidus reads a power of the AlF3 fraction, not a number below 0) it loses that cell at the second
    sample (the first step's rates are not numbers) and holds the others.  A sample not taken (NaN) is not a loss."""
    x, u = truth
    sensors = SensorSet("plant", (Sensor("U_cell", 10.0, 0.005), Sensor("x6", 3600.0, 1.5)))
    table = measure(true_model(), x, u, 10.0, sensors, np.random.default_rng(1))
    y = table[["U_cell", "x6"]].to_numpy().reshape(4, -1, 2)
    noise = np.array([0.005, 1.5])
    start = x[:, 0].copy()
    held = estimate_states(true_model(), y, u, ["U_cell", "x6"], noise, 10.0, backward=False, start=start)
    assert np.isfinite(held.log_likelihood).all() and lost_cells(held.innovation, y, 10.0) == []
    start[2, 2] = -500.0
    lost = estimate_states(true_model(), y, u, ["U_cell", "x6"], noise, 10.0, backward=False, start=start)
    assert np.isfinite(lost.log_likelihood).tolist() == [True, True, False, True]
    assert lost_cells(lost.innovation, y, 10.0) == [LostCell(cell=2, hour=10.0 / 3600)]  # its first step's rates


def test_lost_cells_are_placed_at_their_first_sample_without_innovation():
    """Innovations of 3 cells, 720 steps of 10 s, a channel every step and one every 360 steps: cell 1 has
    none from step 540 (hour 1.5), cell 2 none where nothing was sampled alone."""
    y = np.full((3, 720, 2), 1.0)
    y[:, :, 1] = np.nan
    y[:, ::360, 1] = 1.0
    e = np.where(np.isfinite(y), 0.5, np.nan)
    e[1, 540:] = np.nan
    assert lost_cells(e, y, 10.0) == [LostCell(cell=1, hour=1.5)]
    assert describe_lost([LostCell(0, 1.5)]) == "cell 0 (from hour 1.5)"
    assert describe_lost([LostCell(0, 1.5), LostCell(4, 15.8), LostCell(5, 20.0)]) == (
        "cells 0 (from hour 1.5), 4 (from hour 15.8) and 5 (from hour 20.0)"
    )


def test_a_crane_scale_reads_each_tap_once_and_weighs_what_left_the_cell(truth):
    """The tapping shortfall's cell removes 90 % of the logged u4: its scale reads 0.9 u4 at each tap's first
    step, the same record under the model without the shortfall reads u4, and the other channels' samples do not
    change when the scale is added to a set."""
    x, u = truth
    case = find_case("tapping_shortfall")
    shortfall, _ = case.models(true_model())
    taps = tap_starts(u)
    u4 = u[..., 3]
    assert taps.sum() >= 3 and (u4[taps] > 0).all() and not (taps[:, 1:] & (u4[:, :-1] > 0)).any()
    voltage = Sensor("U_cell", 10.0, 0.005)
    scale = Sensor("m_tap", AT_TAPS, 1e-9)
    with_scale = measure(shortfall, x, u, 10.0, SensorSet("s", (voltage, scale)), np.random.default_rng(3))
    without = measure(shortfall, x, u, 10.0, SensorSet("s", (voltage,)), np.random.default_rng(3))
    weighed = with_scale["m_tap"].to_numpy().reshape(u4.shape)
    assert (np.isfinite(weighed) == taps).all()
    np.testing.assert_allclose(weighed[taps], 0.9 * u4[taps], rtol=1e-6)
    np.testing.assert_allclose(observe(true_model(), x, u, ["m_tap"])[..., 0], u4)
    np.testing.assert_array_equal(with_scale["U_cell"], without["U_cell"])
    assert Sensor("m_tap", AT_TAPS).interval == "at each tap" and voltage.interval == "every 10 s"
    with pytest.raises(ValueError, match="every_s is a number of seconds or 'tap'"):
        Sensor("m_tap", "daily", 1.0)


def test_a_sensor_sets_findings_describe_the_cells_it_simulates(default_config):
    """The data line of a case's findings counts the sensor set's own cells (a pot line: 6 to learn
    from, 3 held out, 5 days), not the discovery's 40 and 20, and gives the case's noise level only
    where a channel takes it."""
    from costa.discover.cases.tables import simulated_data

    assert (
        simulated_data(default_config, "no_effect")
        == "40 simulated trajectories (20 held out) with 1.0% measurement noise"
    )
    assert simulated_data(default_config, "no_effect", "plant") == "12 simulated trajectories of 48 h (6 held out)"
    assert (
        simulated_data(default_config, "top_heat_loss", "pot_line") == "6 simulated trajectories of 120 h (3 held out)"
    )
    assert simulated_data(default_config, "top_heat_loss", "partial").endswith(
        "(20 held out) with 1.0% measurement noise"
    )


def test_a_varied_sets_drawn_case_draws_its_record_and_a_shipped_case_gets_the_set(default_config):
    """Under ``regimes`` each drawn case's record is a function of its seed: its cells run one of the
    operations, for whole hours within the range, and its hand-sampled channels all at one of the intervals
    (the logged voltage as declared); a shipped case, and every set that does not vary, are as declared."""
    from costa.discover.cases.tables import record_settings, simulated_data

    vary = default_config["discovery"]["sensor_sets"]["regimes"]["vary"]
    drawn = [record_settings(default_config, "regimes", f"drawn{seed}") for seed in range(100_000, 100_040)]
    assert record_settings(default_config, "regimes", "drawn100003")[0] == drawn[3][0]  # a function of the seed
    for sensor_set, settings in drawn:
        hand = {s.every_s for s in sensor_set.sensors if s.channel != "U_pot"}
        assert len(hand) == 1 and hand <= set(vary["every_s"]) and sensor_set.sensors[0].every_s == 10
        assert vary["hours"][0] <= sensor_set.hours <= vary["hours"][1] and sensor_set.hours == round(sensor_set.hours)
        assert settings.operation == sensor_set.operation and settings.steps == sensor_set.hours * 360
    assert {s.operation for s, _ in drawn} == set(vary["operation"])
    assert len({next(iter({x.every_s for x in s.sensors[1:]})) for s, _ in drawn}) == len(vary["every_s"])
    shipped, _ = record_settings(default_config, "regimes", "top_heat_loss")
    pot_line, _ = record_settings(default_config, "pot_line", "drawn100003")
    assert (shipped.hours, shipped.operation, shipped.sensors) == (pot_line.hours, pot_line.operation, pot_line.sensors)
    assert "its record drawn: run by the paper's controllers, U_pot every 10 s, x6 every 3600 s" in simulated_data(
        default_config, "drawn100003", "regimes"
    )


def test_a_drawn_record_is_sampled_and_decided_as_drawn(default_config):
    """The table a varied set's drawn case makes samples each channel at its drawn interval over its drawn
    length, and the route its run takes from the table is the one the workflow plans from the drawn
    intervals (hourly hand samples: multiple shooting; every step: the filter)."""
    import copy

    from costa.discover.cases.tables import case_tables, record_settings
    from costa.discover.route import choose_route, record_route

    config = copy.deepcopy(default_config)
    regimes = config["discovery"]["sensor_sets"]["regimes"]
    regimes.update(trajectories=1, held_out_trajectories=1)
    regimes["vary"].update(hours=[20, 20])
    for case in ("drawn100003", "drawn100001"):  # hourly samples, paper's controllers; every step, a pot line
        sensor_set, _ = record_settings(config, "regimes", case)
        train, held_out = case_tables(config, case, "regimes")
        assert len(train) == 20 * 360 and train["x6"].notna().sum() == 20 * 3600 // sensor_set.sensors[1].every_s
        planned = choose_route({s.channel: float(s.every_s) for s in sensor_set.sensors}, dt_s=10.0)
        assert record_route([train, held_out], 10.0) == planned
        assert planned.name == {"drawn100003": "shooting", "drawn100001": "filter"}[case]
