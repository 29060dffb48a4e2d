"""The cell model against facts: SPEC's equations, conservation, hand-computed values, limits."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from scipy.optimize import brentq

from costa.integrate import euler_step, rk4_step
from costa.physics import BalanceTerm, authors_code_parameters, operating_points, paper_printed_parameters, true_model


def spec_rhs(x, u):
    """SPEC section 2 typed out flat, independently of the parts-based implementation."""
    k0, k3, k4, k5, k6, k9 = 2e-5, 1.7e-7, 0.02, 0.03, 4.43e-8, 17.92
    k1, k2 = 2 * 2.5 * 17.92 / 119495, 1200 * 17.92 / 119495
    k7, k8, k12, k13 = k2 * 1881, k1 * 1881, k2 * 1320, k1 * 1320
    k10, k11, k14, k15, k16, k17, k18 = 1 / 1200, 0.2, 0.1 / 13, 0.2, 35.0, 6e-7, 0.04
    alpha, beta = 5.66e-4, 7.58e-4
    x1, x2, x3, x4, x5, x6, x7, x8 = x.T
    u1, u2, u3, u4, u5 = u.T
    m = x2 + x3 + x4
    p2, p3 = 100 * x2 / m, 100 * x3 / m
    g1 = 991.2 + 1.12 * p3 - 0.13 * p3**2.2 + 0.061 * p3**1.5 - 7.93 * p2 / (
        1 + 0.0936 * p3 - 0.0017 * p3**2 - 0.0023 * p3 * p2)  # fmt: skip
    g2 = np.exp(2.496 - 2068.4 / (273 + x6) - 2.07 * x2 / m)
    g3 = 0.531 + 6.958e-7 * u2 - 2.51e-12 * u2**2 + 3.06e-18 * u2**3 + (0.431 - 0.1437 * (p2 - 2.2)) / (
        1 + 7.353 * (p2 - 2.2))  # fmt: skip
    g4 = (0.5517 + 3.8168e-6 * u2) / (1 + 8.271e-6 * u2)
    g5 = 3.8168e-6 * g3 * g4 * u2 / (g2 * (1 - g3))
    U = g5 + u2 * u5 / (2620 * g2)
    w = k1 * (g1 - x7) / (k0 * x1) - k2 * (x6 - g1)
    return np.column_stack([
        w, u1 - k3 * u2, u3 - k4 * u1, -w + k5 * u1, k6 * u2 - u4,
        alpha / m * (u2 * U - k9 * (x6 - x7) / (k10 + k11 * k0 * x1) - k7 * (x6 - g1) ** 2
                     + k8 * (x6 - g1) * (g1 - x7) / (k0 * x1)),
        beta / x1 * (k9 * (g1 - x7) / (k15 * k0 * x1) - k9 * (x7 - x8) / (k14 + k15 * k0 * x1)
                     - k12 * (x6 - g1) * (g1 - x7) + k13 * (g1 - x7) ** 2 / (k0 * x1)),
        k17 * k9 * ((x7 - x8) / (k14 + k15 * k0 * x1) - (x8 - k16) / (k14 + k18)),
    ])  # fmt: skip


def test_true_model_is_specs_equations(model, rng):
    x, u = operating_points(rng, 2000)
    np.testing.assert_allclose(model.rhs(x, u), spec_rhs(x, u), rtol=1e-11, atol=1e-15)


def test_constants_derive_from_material_properties():
    k = authors_code_parameters()
    assert k.k1 == pytest.approx(7.498e-4, rel=1e-4)
    assert k.k2 == pytest.approx(0.17996, rel=1e-4)
    assert k.k7 == pytest.approx(338.5, rel=1e-3)
    assert k.k8 == pytest.approx(1.4104, rel=1e-4)
    assert k.k12 == pytest.approx(237.5, rel=1e-3)
    assert k.k13 == pytest.approx(0.9898, rel=1e-4)
    assert k.k14 == pytest.approx(7.692e-3, rel=1e-4)
    assert (k.k4, k.k17) == (0.02, 6e-7)
    printed = paper_printed_parameters()
    assert (printed.k4, printed.k17) == (0.036, 5.8e-7)


def test_freezing_moves_mass_between_ledge_and_bath(model, rng):
    """dx1/dt + dx4/dt = k5 u1: freezing only moves cryolite between bath and ledge."""
    x, u = operating_points(rng, 5000)
    dx = model.rhs(x, u)
    k5 = model.params.k5
    np.testing.assert_allclose(
        dx[:, 0] + dx[:, 3], k5 * u[:, 0], rtol=0, atol=4 * np.finfo(float).eps * np.abs(dx[:, 0]).max()
    )


def test_linear_states_follow_their_inputs(model, rng):
    x, u = operating_points(rng, 100)
    dx = model.rhs(x, u)
    k = model.params
    np.testing.assert_array_equal(dx[:, 1], u[:, 0] - k.k3 * u[:, 1])
    np.testing.assert_array_equal(dx[:, 2], u[:, 2] - k.k4 * u[:, 0])
    np.testing.assert_array_equal(dx[:, 4], k.k6 * u[:, 1] - u[:, 3])


def _state(c2, c3, x4=15000.0, x1=3000.0, x6=970.0, x7=820.0, x8=580.0, x5=9900.0):
    bath = x4 / (1 - c2 - c3)
    return np.array([x1, c2 * bath, c3 * bath, x4, x5, x6, x7, x8])


def test_liquidus_temperature_at_hand_computed_point(model):
    """c2 = 3 %, c3 = 11 %: 991.2 + 12.32 - 0.13 * 11^2.2 + 0.061 * 11^1.5 - 23.79/1.7480."""
    hand = 991.2 + 1.12 * 11 - 0.13 * math.exp(2.2 * math.log(11)) + 0.061 * 11 * math.sqrt(11) - 7.93 * 3 / (
        1 + 0.0936 * 11 - 0.0017 * 121 - 0.0023 * 33)  # fmt: skip
    g1 = model.quantities(_state(0.03, 0.11), np.array([0, 1.4e5, 0, 0, 0.05]))["liquidus_temperature"]
    assert g1 == pytest.approx(hand, rel=1e-13)
    assert g1 == pytest.approx(966.7255, abs=1e-4)


def test_liquidus_matches_papers_fraction_form(model, rng):
    """The printed form in mass fractions (with 3265.5 = 0.13 * 100^2.2 rounded) agrees to rounding."""
    x, u = operating_points(rng, 500)
    c2, c3 = x[:, 1] / x[:, 1:4].sum(1), x[:, 2] / x[:, 1:4].sum(1)
    printed = (
        991.2 + 112 * c3 + 61 * c3**1.5 - 3265.5 * c3**2.2 - 793 * c2 / (-23 * c2 * c3 - 17 * c3**2 + 9.36 * c3 + 1)
    )
    np.testing.assert_allclose(model.quantities(x, u)["liquidus_temperature"], printed, atol=0.01)


def test_conductivity_and_voltages_at_hand_computed_point(model):
    x, u = _state(0.03, 0.11, x6=970.0), np.array([0.0, 1.4e5, 0.0, 0.0, 0.05])
    q = model.quantities(x, u)
    g2 = math.exp(2.496 - 2068.4 / 1243 - 2.07 * 0.03)
    g3 = (
        0.531 + 6.958e-7 * 1.4e5 - 2.51e-12 * 1.96e10 + 3.06e-18 * 2.744e15 + (0.431 - 0.1437 * 0.8) / (1 + 7.353 * 0.8)
    )
    g4 = (0.5517 + 3.8168e-6 * 1.4e5) / (1 + 8.271e-6 * 1.4e5)
    g5 = 3.8168e-6 * g3 * g4 * 1.4e5 / (g2 * (1 - g3))
    assert q["bath_conductivity"] == pytest.approx(g2, rel=1e-12)
    assert q["bath_conductivity"] == pytest.approx(2.15947, abs=1e-5)
    assert q["bubble_thickness"] == pytest.approx(g4, rel=1e-12)
    assert q["bubble_coverage"] == pytest.approx(g3, rel=1e-12)
    assert q["bubble_voltage"] == pytest.approx(g5, rel=1e-12)
    assert q["bubble_voltage"] == pytest.approx(0.215291, abs=1e-6)
    assert q["cell_voltage"] == pytest.approx(g5 + 1.4e5 * 0.05 / (2620 * g2), rel=1e-12)


def test_bubble_voltage_diverges_at_anode_effect(model):
    """g3 -> 1 as the alumina fraction falls towards the critical 2.2 %: the anode effect."""
    u = np.array([0.0, 1.4e5, 0.0, 0.0, 0.05])
    g3 = lambda c2: model.quantities(_state(c2, 0.11), u)["bubble_coverage"] - 1  # noqa: E731
    c_anode = brentq(g3, 0.02201, 0.03)
    assert 0.0220 < c_anode < 0.0222
    g5 = [model.quantities(_state(c_anode + d, 0.11), u)["bubble_voltage"] for d in (1e-3, 1e-5, 1e-7)]
    assert g5[0] < g5[1] < g5[2] and g5[2] > 100


def test_ablated_model_equals_true_model_where_liquidus_is_968(model, pbm):
    u = np.array([5.0, 1.3e5, 1.0, 2.0, 0.052])
    for c2 in (0.022, 0.025, 0.03):  # at c2 >= 4 % g1 < 968 for any c3
        c3 = brentq(lambda c3, c2=c2: model.quantities(_state(c2, c3), u)["liquidus_temperature"] - 968.0, 0.01, 0.2)
        x = _state(c2, c3)
        assert model.quantities(x, u)["liquidus_temperature"] == pytest.approx(968.0, abs=1e-9)
        np.testing.assert_allclose(pbm.rhs(x, u), model.rhs(x, u), rtol=1e-9, atol=1e-12)


def test_ablation_changes_only_the_liquidus_dependent_balances(model, pbm, rng):
    x, u = operating_points(rng, 200)
    true, ablated = model.rhs(x, u), pbm.rhs(x, u)
    for i in (1, 2, 4, 7):  # x2, x3, x5, x8 do not read g1
        np.testing.assert_array_equal(true[:, i], ablated[:, i])
    for i in (0, 3, 5, 6):
        assert np.all(true[:, i] != ablated[:, i])
    np.testing.assert_array_equal(pbm.quantities(x, u)["liquidus_temperature"], 968.0)


def test_numpy_and_torch_agree(model, rng):
    x, u = operating_points(rng, 300)
    from_torch = model.rhs(torch.from_numpy(x), torch.from_numpy(u)).numpy()
    np.testing.assert_allclose(from_torch, model.rhs(x, u), rtol=1e-12, atol=1e-16)


def test_torch_gradients_flow_through_the_model(model, rng):
    x, u = operating_points(rng, 4)
    xt = torch.from_numpy(x).requires_grad_()
    model.rhs(xt, torch.from_numpy(u))[:, 5].sum().backward()
    assert torch.isfinite(xt.grad).all() and (xt.grad[:, 5] != 0).all()


def test_model_broadcasts_over_batch_shapes(model, rng):
    x, u = operating_points(rng, 12)
    flat = model.rhs(x, u)
    np.testing.assert_array_equal(model.rhs(x.reshape(3, 4, 8), u.reshape(3, 4, 5)).reshape(12, 8), flat)
    np.testing.assert_array_equal(model.rhs(x[0], u[0]), flat[0])


@pytest.mark.parametrize(("step", "order"), [(rk4_step, 4), (euler_step, 1)])
def test_integrator_convergence_order_on_the_cell_model(model, step, order):
    """Halving dt divides the error at T = 2000 s by 2^order (constant inputs)."""
    x0, u = _state(0.03, 0.11), np.array([0.0, 1.4e5, 0.0, 0.0, 0.05])

    def solve(dt):
        x = x0.copy()
        for _ in range(round(2000 / dt)):
            x = step(model.rhs, x, u, dt)
        return x

    reference = solve(2000 / 4096) if order == 1 else solve(2000 / 512)
    errors = [np.abs((solve(dt) - reference) / reference).max() for dt in (200, 100, 50)]
    observed = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(observed - order) < 0.35), observed


def test_balance_terms_add_flows_in_physical_units(model, rng):
    x, u = operating_points(rng, 50)
    top_loss = BalanceTerm(
        "top_heat_loss", "20 kW", "W", {"bath_energy": -1.0}, lambda v, k, q: v.xp.full_like(v.x1, 2e4)
    )
    changed = model.with_terms(top_loss)
    difference = changed.rhs(x, u) - model.rhs(x, u)
    m = x[:, 1:4].sum(1)
    np.testing.assert_allclose(difference[:, 5], -model.params.alpha / m * 2e4, rtol=1e-9)
    np.testing.assert_array_equal(np.delete(difference, 5, axis=1), 0)
    with pytest.raises(ValueError, match="is in W but balance 'alumina_mass'"):
        BalanceTerm("bad", "", "W", {"alumina_mass": 1.0}, top_loss.fn)
    with pytest.raises(ValueError, match="unknown part 'liquidus'"):
        model.with_part("liquidus", model.parts["liquidus_temperature"])


def test_printed_variant_reads_the_alumina_feed_in_g3_and_drops_k9(rng):
    printed, code = true_model(variant="paper_printed"), true_model()
    x, u = operating_points(rng, 100)
    u_changed = u.copy()
    u_changed[:, 1] *= 1.1
    g3 = lambda m, uu: m.quantities(x, uu)["bubble_coverage"]  # noqa: E731
    np.testing.assert_array_equal(g3(printed, u), g3(printed, u_changed))
    assert np.all(g3(code, u) != g3(code, u_changed))
    k = code.params
    q = code.quantities(x, u)
    wall_printed = k.beta / x[:, 0] * (q["ledge_wall_heat"] / k.k9)
    dx7_printed_wall_only = code.rhs(x, u)[:, 6] + k.beta / x[:, 0] * q["ledge_wall_heat"] - wall_printed
    printed_same_g3 = printed.with_part("bubble_coverage", code.parts["bubble_coverage"])
    np.testing.assert_allclose(printed_same_g3.rhs(x, u)[:, 6], dx7_printed_wall_only, rtol=1e-10)


@pytest.mark.parametrize(
    ("prop", "material_field"),
    [
        ("ledge_conductivity", "ledge_conductivity"),
        ("wall_conductivity", "wall_conductivity"),
        ("bath_ledge_heat_transfer", "bath_ledge_heat_transfer"),
        ("wall_ambient_heat_transfer", "wall_ambient_heat_transfer"),
        ("fusion_enthalpy", "cryolite_fusion_enthalpy"),
        ("liquid_cryolite_heat_capacity", "liquid_cryolite_heat_capacity"),
        ("solid_cryolite_heat_capacity", "solid_cryolite_heat_capacity"),
        ("ledge_area", "ledge_area"),
        ("ledge_density", "ledge_density"),
        ("bath_heat_capacity", "bath_heat_capacity"),
        ("ledge_heat_capacity", "ledge_heat_capacity"),
        ("wall_heat_capacity", "wall_heat_capacity"),
    ],
)
def test_property_corrections_equal_rederiving_the_constants(model, rng, prop, material_field):
    """Scaling a property through its exponents = deriving every constant from the scaled material data."""
    import dataclasses

    from costa.physics import PROPERTIES, MaterialProperties, PropertyCorrection

    x, u = operating_points(rng, 100)
    corrected = model.with_property(PropertyCorrection(PROPERTIES[prop], "0.1", lambda v: 0.1 + 0 * v.x1))
    material = MaterialProperties()
    changed = dataclasses.replace(material, **{material_field: 1.1 * getattr(material, material_field)})
    rederived = dataclasses.replace(model, params=authors_code_parameters(changed))
    np.testing.assert_allclose(corrected.rhs(x, u), rederived.rhs(x, u), rtol=1e-12, atol=1e-15)


def test_a_property_may_vary_with_the_state(model, rng):
    from costa.physics import PROPERTIES, PropertyCorrection

    x, u = operating_points(rng, 50)
    varying = model.with_property(
        PropertyCorrection(PROPERTIES["bath_heat_capacity"], "0.01 (x6 - 970)", lambda v: 0.01 * (v.x6 - 970))
    )
    np.testing.assert_allclose(
        varying.rhs(x, u)[:, 5], model.rhs(x, u)[:, 5] / (1 + 0.01 * (x[:, 5] - 970)), rtol=1e-12
    )
    np.testing.assert_array_equal(varying.rhs(x, u)[:, :5], model.rhs(x, u)[:, :5])
    assert "bath_heat_capacity x (1 + 0.01 (x6 - 970))" in varying.describe()


#: The constants of the authors' code (its literals and its derivation), as the code computes them.
AUTHORS_CODE_CONSTANTS = {
    "k0": 2e-05,
    "k1": 0.0007498221682915604,
    "k2": 0.1799573203899745,
    "k3": 1.7e-07,
    "k4": 0.02,
    "k5": 0.03,
    "k6": 4.43e-08,
    "k7": 338.49971965354206,
    "k8": 1.4104154985564252,
    "k9": 17.92,
    "k10": 0.0008333333333333334,
    "k11": 0.2,
    "k12": 237.54366291476634,
    "k13": 0.9897652621448597,
    "k14": 0.007692307692307693,
    "k15": 0.2,
    "k16": 35.0,
    "k17": 6e-07,
    "k18": 0.04,
    "alpha": 0.000566,
    "beta": 0.000758,
    "critical_alumina_percent": 2.2,
}
#: ... and the default cell's pot voltage beyond the bath (channel U_pot): back EMF [V], resistance [ohm]
DEFAULT_CELL_CONSTANTS = AUTHORS_CODE_CONSTANTS | {"E0": 1.8, "R_ext": 6.8e-6}


def test_the_default_cell_gives_the_authors_constants_bit_for_bit():
    from costa.config import load_config
    from costa.physics import model_from_config

    assert authors_code_parameters().as_dict() == DEFAULT_CELL_CONSTANTS
    assert model_from_config(load_config()["physics"])[0].params.as_dict() == DEFAULT_CELL_CONSTANTS


@pytest.mark.parametrize(
    ("field", "value", "changed"),
    [
        ("wall_conductivity", 13.0, {"k14": 0.1 / (2 * 13.0)}),
        ("ledge_conductivity", 3.0, {"k1": None, "k8": None, "k13": None, "k11": 1 / 6.0, "k15": 1 / 6.0}),
        ("ledge_area", 20.0, {n: None for n in ("k0", "k1", "k2", "k7", "k8", "k12", "k13")} | {"k9": 20.0}),
        ("ambient_temperature", 20.0, {"k16": 20.0}),
        ("wall_heat_capacity", 2.0e6, {"k17": 5e-7}),
        ("bath_heat_capacity", 2000.0, {"alpha": 5e-4}),
        ("back_emf", 1.7, {"E0": 1.7}),
        ("external_resistance", 5e-6, {"R_ext": 5e-6}),
    ],
)
def test_a_cell_property_changes_exactly_the_constants_it_enters(field, value, changed):
    """A property set in physics.cell changes the constants its derivation names, and no other."""
    from costa.config import load_config
    from costa.physics import model_from_config

    params = model_from_config(load_config(overrides={"physics": {"cell": {field: value}}})["physics"])[0].params
    differ = {k for k, v in params.as_dict().items() if v != DEFAULT_CELL_CONSTANTS[k]}
    assert differ == set(changed)
    for name, expected in changed.items():
        if expected is not None:
            assert getattr(params, name) == pytest.approx(expected, rel=1e-15)


def test_a_changed_ledge_conductivity_rescales_its_constants_by_the_derivation():
    from costa.physics import MaterialProperties

    base, changed = authors_code_parameters(), authors_code_parameters(MaterialProperties(ledge_conductivity=5.0))
    for name, exponent in {"k1": 1, "k8": 1, "k13": 1, "k11": -1, "k15": -1}.items():
        assert getattr(changed, name) == pytest.approx(getattr(base, name) * 2.0**exponent, rel=1e-14)


def test_overrides_win_over_the_cell_and_the_table_says_where_each_constant_comes_from():
    from costa.config import load_config
    from costa.physics import constants_table

    physics = load_config(overrides={"physics": {"cell": {"ledge_area": 20.0}, "overrides": {"k9": 18.0}}})["physics"]
    table = constants_table(physics).set_index("constant")
    assert table.loc["k9", ["value", "source"]].tolist() == [18.0, "override"]
    assert table.loc["k0", "value"] == pytest.approx(1 / (2790.178571428571 * 20.0), rel=1e-15)
    assert table.loc["k0", "source"] == "1 / (ledge_density ledge_area)"
    assert table.loc["k3", "source"] == "fixed"
    assert table.loc["k14", "unit"] == "m^2 K/W"


def test_the_printed_table_cannot_take_a_cell():
    from costa.config import ConfigError, load_config

    with pytest.raises(ConfigError, match="physics.cell sets material data, but physics.constants = paper_printed"):
        load_config(overrides={"physics": {"constants": "paper_printed", "cell": {"ledge_area": 20.0}}})


# Faraday's law, from the constants' published values: F (CODATA 2018, exact), M(Al) and M(Al2O3) [kg/mol]
FARADAY, M_AL, M_AL2O3 = 96485.33212, 0.026981538, 0.1019613


def _cell_params(**cell):
    from costa.config import load_config
    from costa.physics import model_from_config

    return model_from_config(load_config(overrides={"physics": {"cell": cell}})["physics"])[0].params


def test_a_cell_at_full_current_efficiency_makes_faradays_metal():
    """CE = 1: k6 = M(Al)/(3F) (0.3356 g of aluminium per ampere-hour) and k3 = M(Al2O3)/(6F)."""
    params = _cell_params(current_efficiency=1.0)
    assert params.k6 == pytest.approx(M_AL / (3 * FARADAY), rel=1e-12)
    assert params.k3 == pytest.approx(M_AL2O3 / (6 * FARADAY), rel=1e-12)
    assert params.k6 * 3600 * 1000 == pytest.approx(0.3356, abs=5e-5)  # g/(A h), the electrochemical equivalent


@pytest.mark.parametrize("efficiency", [0.5, 0.93, 0.95, 1.0])
def test_alumina_used_per_metal_made_is_the_stoichiometry_at_any_efficiency(efficiency):
    """2 Al2O3 -> 4 Al: 1.8895 kg of alumina per kg of metal, whatever share of the current makes metal;
    the efficiency scales both, and changes no other constant."""
    params = _cell_params(current_efficiency=efficiency)
    assert params.k3 / params.k6 == pytest.approx(M_AL2O3 / (2 * M_AL), rel=1e-12)
    assert params.k3 / params.k6 == pytest.approx(1.8895, abs=1e-4)
    assert params.k6 == pytest.approx(efficiency * M_AL / (3 * FARADAY), rel=1e-12)
    differ = {k for k in AUTHORS_CODE_CONSTANTS if getattr(params, k) != AUTHORS_CODE_CONSTANTS[k]}
    assert differ == {"k3", "k6"}


def test_the_replication_keeps_the_coded_half_of_faradays_metal():
    """No current efficiency (the default config): the authors' numbers exactly, k6 = 47.5 % of Faraday's."""
    params = _cell_params()
    assert (params.k3, params.k6) == (1.7e-7, 4.43e-8)
    assert params.k6 / (M_AL / (3 * FARADAY)) == pytest.approx(0.475, abs=1e-3)


def test_the_constants_table_names_faradays_law_and_overrides_still_win():
    from costa.config import load_config
    from costa.physics import constants_table

    cell = {"current_efficiency": 0.95}
    physics = load_config(overrides={"physics": {"cell": cell, "overrides": {"k3": 1.7e-7}}})["physics"]
    table = constants_table(physics).set_index("constant")
    assert table.loc["k6", "source"] == "Faraday's law: current_efficiency M(Al) / (3 F)"
    assert table.loc["k6", "value"] == pytest.approx(8.855e-8, rel=1e-4)
    assert table.loc["k3", ["value", "source"]].tolist() == [1.7e-7, "override"]


@pytest.mark.parametrize("efficiency", [0.4, 1.05])
def test_a_current_efficiency_out_of_bounds_is_named(efficiency):
    from costa.config import ConfigError, load_config

    with pytest.raises(ConfigError, match="physics.cell.current_efficiency"):
        load_config(overrides={"physics": {"cell": {"current_efficiency": efficiency}}})
