"""A pot line's operation (costa.pot_line) against what a smelter's controllers must do: hold the current,
feed the alumina the cell consumes, tap the metal it makes once a day, dose AlF3 once a shift."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from costa.observe import observe
from costa.pot_line import DAY_S, SHIFT_S
from costa.simulate import SimulationSettings, simulate_set

DAYS = 2


@pytest.fixture(scope="module")
def line_run(default_config, model):
    settings = SimulationSettings.from_config(default_config["simulation"])
    settings = dataclasses.replace(settings, steps=int(DAYS * DAY_S / settings.dt), operation="pot_line")
    trajectories, _ = simulate_set(model, settings, 3, seed=4, replicate=0, stream_name="pot_line")
    return settings, trajectories


def test_the_line_current_is_held_with_its_ripple(line_run):
    settings, run = line_run
    current = run.u[..., 1]
    line = settings.pot_line
    assert abs(current.mean() / line.current_a - 1) < 1e-4
    assert current.std() / line.current_a == pytest.approx(line.current_noise, rel=0.02)


def test_the_feeders_deliver_what_the_cell_consumes_in_doses(line_run, model):
    settings, run = line_run
    dose_rate = settings.pot_line.dose_kg / settings.dt
    u1 = run.u[..., 0]
    assert set(np.unique(u1)) <= {0.0, dose_rate}  # point-feeder doses, nothing in between
    applied = run.u[:, :-1]  # u_k acts over step k; the last sample's inputs act on nothing recorded
    fed = applied[..., 0].sum(axis=1) * settings.dt
    consumed = model.params.k3 * applied[..., 1].sum(axis=1) * settings.dt
    alumina_change = run.x[:, -1, 1] - run.x[:, 0, 1]
    np.testing.assert_allclose(fed - consumed, alumina_change, rtol=0, atol=1e-3)  # the Al2O3 balance, to a gram
    # tracked on the voltage: the bath neither starves (the voltage's swings below 2.3 %) nor silts up
    fraction = run.x[..., 1] / run.x[..., 1:4].sum(axis=-1)
    assert fraction.min() > 0.023 and fraction.max() < 0.06
    assert abs(fed.sum() / consumed.sum() - 1) < 0.1


def test_one_tap_a_day_takes_the_metal_made_and_alf3_comes_once_a_shift(line_run, model):
    settings, run = line_run
    line = settings.pot_line
    tapping = run.u[..., 3] > 0
    starts = (tapping[:, 1:] & ~tapping[:, :-1]).sum(axis=1) + tapping[:, 0]
    assert set(starts) <= {DAYS, DAYS + 1}  # the first day's tap falls at a random hour
    assert tapping.sum(axis=1).max() <= (DAYS + 1) * line.tap_s / settings.dt
    assert run.u[..., 3].max() < 9.0  # a tap over 10 minutes, within the simulations' range
    applied = run.u[:, :-1]
    made = model.params.k6 * applied[..., 1].sum(axis=1) * settings.dt
    tapped = applied[..., 3].sum(axis=1) * settings.dt
    np.testing.assert_allclose(run.x[:, -1, 4] - run.x[:, 0, 4], made - tapped, rtol=0, atol=1e-3)  # the metal balance
    assert np.all(np.abs(run.x[:, -1, 4] - line.metal_setpoint_kg) < 1.2 * made / DAYS)
    doses = (run.u[..., 2] > 0).sum(axis=1)
    assert set(doses) <= {DAYS * DAY_S / SHIFT_S, DAYS * DAY_S / SHIFT_S + 1}


def test_the_beam_holds_the_voltage_near_its_target(line_run, model):
    settings, run = line_run
    voltage = observe(model, run.x, run.u, ("U_cell",))[..., 0]
    last_day = voltage[:, -int(DAY_S / settings.dt) :]
    assert np.abs(np.median(last_day, axis=1) - settings.pot_line.voltage_target_v).max() < 0.05
    assert np.abs(np.diff(run.u[..., 4], axis=1)).max() <= settings.pot_line.beam_step_m + 1e-12


@pytest.mark.integration  # a minute: a 3-day record of two cells, filtered
def test_a_correct_model_passes_every_channel_test_on_a_pot_lines_daily_samples(default_config, model):
    """No false alarm: the pot voltage every 10 s and daily bath temperature, AlF3 and metal samples of
    cells run by the pot line's controllers, filtered with the model that made them.  The voltage's
    innovations are unit noise: its noise std is estimated net of the line current's ripple (without
    that, 1.8 times the sensor's 5 mV, and a chi-square of 0.32 that would hide an effect)."""
    from costa.discover.pipeline import settings_from_config
    from costa.discover.sparse.pipeline import checked_observations
    from costa.discover.sparse.rounds import channel_tests
    from costa.sensors import measure, sensor_sets_from_config

    sensors = sensor_sets_from_config(default_config["discovery"]["sensor_sets"])["pot_line"]
    settings = SimulationSettings.from_config(default_config["simulation"])
    settings = dataclasses.replace(settings, steps=int(3 * DAY_S / settings.dt), operation="pot_line")
    run, _ = simulate_set(model, settings, 2, seed=1, replicate=0, stream_name="pot_line/null")
    table = measure(model, run.x, run.u, settings.dt, sensors, np.random.default_rng(1))
    declared = {s.channel: s.noise for s in sensors.sensors}
    discovery = settings_from_config(default_config)
    obs = checked_observations(table, declared, "pot line", discovery).with_start(model)
    tests, _ = channel_tests(model, obs, discovery)
    assert {t.channel for t in tests} == {"U_pot", "x6", "c3", "x5"}
    assert not [t for t in tests if t.flagged], tests
    assert obs.noise[obs.channels.index("U_pot")] == pytest.approx(declared["U_pot"], rel=0.05)
    assert 0.8 < next(t.chi2_per_dof for t in tests if t.channel == "U_pot") < 1.25, tests


def _operation_with_anodes(default_config, model, every_s: float, tau_s: float, cells: int = 2):
    from costa.pot_line import PotLine, PotLineOperation

    line = dataclasses.replace(
        PotLine.from_config(default_config["simulation"]["pot_line"]), anode_change_s=every_s, anode_heat_tau_s=tau_s
    )
    dt = default_config["simulation"]["dt_s"]
    return line, dt, PotLineOperation(line, model, dt, np.zeros((cells, 100_000)), np.zeros(cells))


def test_a_new_anode_takes_its_own_heat_from_the_bath(default_config, model):
    """Each new anode takes anode_kg x anode_heat_j_per_kg from the bath, no more and no less: two
    changes (days 1 and 2, a heat uptake of 1 h) over 3 days take twice one anode's heat."""
    line, dt, operation = _operation_with_anodes(default_config, model, every_s=DAY_S, tau_s=3600.0)
    x = np.tile([3000.0, 500.0, 1800.0, 14000.0, 10000.0, 970.0, 820.0, 580.0], (2, 1))
    taken = 0.0
    for k in range(int(3 * DAY_S / dt)):
        operation.inputs(x, k)
        taken = taken + operation.bath_heat_taken() * dt
    np.testing.assert_allclose(taken, 2 * line.anode_kg * line.anode_heat_j_per_kg, rtol=1e-9)


def test_the_heat_an_anode_takes_cools_the_bath_by_its_heat_capacity(default_config, model):
    """The step after a change, the bath is cooler than the undisturbed cell's by Q dt / (m c_p,bath):
    m the bath's mass x2 + x3 + x4, c_p,bath 1767 J/(kg K)."""
    from costa.simulate import simulate

    line, dt, operation = _operation_with_anodes(default_config, model, every_s=60.0, tau_s=3600.0)
    settings = dataclasses.replace(SimulationSettings.from_config(default_config["simulation"]), steps=8)
    x0 = np.tile([3000.0, 500.0, 1800.0, 14000.0, 10000.0, 970.0, 820.0, 580.0], (2, 1))
    disturbed = simulate(model, x0, operation, settings)
    _, _, undisturbed = _operation_with_anodes(default_config, model, every_s=0.0, tau_s=3600.0)
    plain = simulate(model, x0, undisturbed, settings)
    heat = line.anode_kg * line.anode_heat_j_per_kg * -np.expm1(-dt / line.anode_heat_tau_s) / dt  # W, the first step
    change = int(60.0 / dt)  # the step the first anode is set
    bath = disturbed.x[:, change, 1:4].sum(axis=1)
    assert np.all(disturbed.x[:, : change + 1] == plain.x[:, : change + 1])
    cooler = plain.x[:, change + 1, 5] - disturbed.x[:, change + 1, 5]
    np.testing.assert_allclose(cooler, heat * dt / (bath * 1766.7844522968198), rtol=1e-3)
