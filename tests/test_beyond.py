"""Beyond the paper's forecasts: smoothed targets, the bounded CoSTA, noisy training sets."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import torch

from costa.beyond import noisy_table
from costa.data import arrays, to_table
from costa.ensemble import MLPEnsemble
from costa.forecast import rollout_physics
from costa.models import NetworkModel, load_models, save_instance
from costa.physics import operating_points
from costa.train import ModelType, Normalisation, train_model_type, training_data

DT = 10.0


def varying_inputs(rng, n, steps):
    """Inputs held for 10 steps at random operating values (every input varies)."""
    _, u = operating_points(rng, n * steps // 10)
    return np.repeat(u.reshape(n, steps // 10, 5), 10, axis=1)


def test_smoothed_targets_of_a_cubic_equal_its_forward_differences(rng):
    """Forward differences of a cubic are a quadratic in k, which a Savitzky-Golay filter
    of order 2 reproduces exactly (edges included): smoothing must change nothing."""
    n, steps = 2, 80
    k = np.arange(steps)[None, :, None]
    coefficients = rng.normal(size=(4, n, 1, 8))
    x = 1000 + sum(c * (k / steps) ** p * 10 for p, c in enumerate(coefficients))
    u = varying_inputs(rng, n, steps)
    plain = training_data(x, u, DT, "ddm")
    smoothed = training_data(x, u, DT, "ddm", savgol={"window": 11, "order": 2})
    torch.testing.assert_close(smoothed.targets, plain.targets, rtol=1e-4, atol=1e-4)
    np.testing.assert_allclose(smoothed.normalisation.rate_std, plain.normalisation.rate_std, rtol=1e-9)


def test_smoothed_targets_remove_most_of_the_measurement_noise(rng):
    n, steps = 4, 1000
    t = np.arange(steps)[None, :, None] * DT
    clean = 1000 + 20 * np.sin(2 * np.pi * t / 20000 + rng.uniform(0, 6, (n, 1, 8)))
    noisy = clean + rng.normal(size=clean.shape) * 0.2
    u = varying_inputs(rng, n, steps)
    truth = (clean[:, 1:] - clean[:, :-1]) / DT
    errors = {}
    for name, savgol in (("forward", None), ("smoothed", {"window": 31, "order": 2})):
        data = training_data(noisy, u, DT, "ddm", savgol=savgol)
        n_ = data.normalisation
        rates = data.targets.double().numpy() * n_.rate_std + n_.rate_mean
        errors[name] = np.sqrt(np.mean((rates - truth.reshape(-1, 8)) ** 2))
    # white noise of std s: forward differences have std sqrt(2) s / dt
    assert errors["forward"] == pytest.approx(np.sqrt(2) * 0.2 / DT, rel=0.05)
    assert errors["smoothed"] < 0.1 * errors["forward"]


def test_smoothed_costa_target_keeps_input_steps_out_of_the_filter(rng, pbm):
    """Data that follow the PBM exactly (forward Euler) have a zero CoSTA residual, however
    the held inputs jump; smoothing the residual keeps it zero, where smoothing the rates alone would not."""
    n, steps = 3, 200
    x0, _ = operating_points(rng, n)
    u = varying_inputs(rng, n, steps)
    start = np.zeros((n, steps, 8))
    start[:, 0] = x0
    x = rollout_physics(pbm, start, u, DT, method="euler")
    for savgol in (None, {"window": 21, "order": 2}):
        data = training_data(x, u, DT, "costa", pbm, savgol)
        assert np.abs(data.targets.numpy()).max() < 1e-4, savgol
    rates = (x[:, 1:] - x[:, :-1]) / DT
    assert not np.allclose(training_data(x, u, DT, "ddm", savgol={"window": 21, "order": 2}).normalisation.rate_std,
                           rates.reshape(-1, 8).std(0, ddof=1), rtol=1e-3)  # fmt: skip


def test_bad_smoothing_window_is_named(rng):
    x = rng.normal(size=(1, 20, 8))
    with pytest.raises(ValueError, match="savgol.window"):
        training_data(x, varying_inputs(rng, 1, 20), DT, "ddm", savgol={"window": 31, "order": 2})
    with pytest.raises(ValueError, match="savgol.order"):
        ModelType("m", "ddm", 0.0, savgol={"window": 5, "order": 5})


def bounded_pair(rng, pbm, margin, inputs):
    """A random 3-member CoSTA ensemble, plain and bounded, on operating points of the cell.

    The training ranges are set by hand: standardised inputs in [-1.5, 1.5], targets in
    [-a, b] per state.  Returns the two models, the normalisation and a source function
    (the correction NN(z) = (rhs - f_PBM) / std(r)) at states x and inputs u.
    """
    x, u = operating_points(rng, 500)
    samples = np.concatenate([x, u], axis=1)
    generators = [torch.Generator().manual_seed(i) for i in range(3)]
    ensemble = MLPEnsemble.kaiming([13, 16, 16, 8], generators)
    normalisation = Normalisation(
        samples.mean(0), samples.std(0), np.zeros(8), np.full(8, 0.01),
        input_low=np.full(13, -1.5), input_high=np.full(13, 1.5),
        target_low=-rng.uniform(0.1, 0.5, 8), target_high=rng.uniform(0.1, 0.5, 8),
    )  # fmt: skip
    plain = NetworkModel(ModelType("costa_sparse", "costa", 1e-4), ensemble, normalisation, pbm, {})
    bounded_type = ModelType("costa_bounded", "costa", 1e-4, source_bound={"margin": margin, "inputs": inputs})
    bounded = NetworkModel(bounded_type, ensemble, normalisation, pbm, {})

    def source(model, x, u):
        xt, ut = torch.from_numpy(x), torch.from_numpy(u)
        return (model.rhs(xt.expand(3, -1, -1), ut) - torch.from_numpy(pbm.rhs(x, u))) / 0.01

    return plain, bounded, normalisation, source, x, u


@pytest.mark.parametrize("margin", [0.0, 0.25])
def test_bounded_source_never_leaves_its_bound_and_equals_costa_inside(rng, pbm, margin):
    plain, bounded, n, source, x, u = bounded_pair(rng, pbm, margin, inputs=False)
    free, held = source(plain, x, u), source(bounded, x, u)
    width = margin * (n.target_high - n.target_low)
    low, high = torch.from_numpy(n.target_low - width), torch.from_numpy(n.target_high + width)
    tolerance = 1e-6  # the network runs in float32
    assert (held >= low - tolerance).all() and (held <= high + tolerance).all()
    inside = (free >= low) & (free <= high)
    assert 0.05 < inside.double().mean() < 0.95  # both cases occur
    torch.testing.assert_close(held[inside], free[inside])
    torch.testing.assert_close(held[~inside], torch.clamp(free, low, high)[~inside])


def test_input_clamp_changes_only_inputs_outside_the_training_range(rng, pbm):
    plain, bounded, n, source, x, u = bounded_pair(rng, pbm, margin=1e6, inputs=True)
    z = (np.concatenate([x, u], axis=1) - n.input_mean) / n.input_std
    inside = np.abs(z).max(axis=1) <= 1.5
    assert 0 < inside.sum() < len(z)
    torch.testing.assert_close(source(bounded, x[inside], u[inside]), source(plain, x[inside], u[inside]))
    clamped = np.clip(z, -1.5, 1.5) * n.input_std + n.input_mean  # where the clamped network is asked
    # the network sees the clamped inputs (the PBM still sees the true state)
    network_at_clamped = source(plain, clamped[:, :8], clamped[:, 8:])
    torch.testing.assert_close(source(bounded, x, u), network_at_clamped, rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize("margin", [0.0, 0.1])
def test_rate_bound_keeps_every_rate_in_the_training_range_and_equals_costa_inside(rng, pbm, margin):
    x, u = operating_points(rng, 500)
    plain, _, n, _, _, _ = bounded_pair(rng, pbm, 0.0, inputs=False)
    free = plain.rhs(torch.from_numpy(x).expand(3, -1, -1), torch.from_numpy(u))
    # the training rates span the middle 80 % of these rates, so that some fall outside
    low, high = np.quantile(free.numpy().reshape(-1, 8), [0.1, 0.9], axis=0)
    ranged = Normalisation(**{**vars(n), "rate_low": low, "rate_high": high})
    bounded_type = ModelType("costa_rate_bounded", "costa", 1e-4, rate_bound={"margin": margin})
    bounded = NetworkModel(bounded_type, plain.ensemble, ranged, pbm, {})
    held = bounded.rhs(torch.from_numpy(x).expand(3, -1, -1), torch.from_numpy(u))
    width = margin * (high - low)
    low, high = torch.from_numpy(low - width), torch.from_numpy(high + width)
    assert (held >= low).all() and (held <= high).all()
    inside = (free >= low) & (free <= high)
    assert 0.3 < inside.double().mean() < 0.99
    torch.testing.assert_close(held[inside], free[inside], rtol=0, atol=0)
    torch.testing.assert_close(held, torch.clamp(free, low, high), rtol=0, atol=0)


def test_bounded_and_smoothed_types_train_save_and_reload(smoke_config, smoke_train, tmp_path):
    x, u = smoke_train
    config = copy.deepcopy(smoke_config)
    config["training"]["model_types"] = {
        "costa_bounded": {
            "target": "costa",
            "l1_lambda": 1e-4,
            "source_bound": {"margin": 0.0, "inputs": True},
            "rate_bound": {"margin": 0.0},
        },
        "costa_smooth": {"target": "costa", "l1_lambda": 1e-4, "savgol": {"window": 11, "order": 2}},
    }
    for name in config["training"]["model_types"]:
        fitted = train_model_type(config, name, x, u, replicate=0)
        n = fitted.normalisation
        data = training_data(x, u, DT, "costa", load_models_pbm(config), fitted.model_type.savgol)
        np.testing.assert_array_equal(n.target_low, data.targets.numpy().min(0))
        assert (n.rate_low < n.rate_high).all()
        paths = [tmp_path / f"{name}{i}.pt" for i in range(2)]
        for member, path in enumerate(paths):
            save_instance(path, fitted.ensemble, member, fitted.model_type, n, config, {})
        reloaded = load_models(paths)
        assert reloaded.model_type == fitted.model_type
        np.testing.assert_array_equal(reloaded.normalisation.input_high, n.input_high)


def load_models_pbm(config):
    from costa.physics import model_from_config

    return model_from_config(config["physics"])[1]


def test_noisy_training_set_has_the_asked_noise_and_is_reproducible(smoke_train):
    x, u = smoke_train
    table = to_table(x, u, DT)
    noisy = noisy_table(table, 5.0, seed=7, replicate=0)
    again = noisy_table(table, 5.0, seed=7, replicate=0)
    other = noisy_table(table, 5.0, seed=7, replicate=1)
    xn, un = arrays(noisy)
    np.testing.assert_array_equal(un, u)
    relative = (xn - x).reshape(-1, 8).std(0) / x.reshape(-1, 8).std(0)
    np.testing.assert_allclose(relative, 0.05, rtol=0.1)
    assert noisy.equals(again) and not noisy.equals(other)
