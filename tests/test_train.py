"""Training: the stacked ensemble against separate modules, targets, l1, artifacts, errors."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import torch

from costa import seeds
from costa.config import ConfigError, load_config
from costa.ensemble import MLPEnsemble, StackedAdam, ensemble_gradients
from costa.models import load_models, save_instance
from costa.train import (
    ModelType,
    NonFiniteLossError,
    TrainingData,
    TrainingSettings,
    compiled_or_eager,
    prune,
    sparsity,
    train_ensemble,
    train_model_type,
    training_data,
)

SIZES = [13, 20, 20, 20, 20, 8]


def generators(n, name="g"):
    return [seeds.torch_generator(1, 0, name, i) for i in range(n)]


def test_kaiming_initialisation_has_the_right_scale_and_zero_biases():
    ensemble = MLPEnsemble.kaiming([400, 300, 8], generators(4))
    assert ensemble.weights[0].std().item() == pytest.approx(np.sqrt(2 / 400), rel=0.02)
    assert ensemble.weights[1].std().item() == pytest.approx(np.sqrt(2 / 300), rel=0.05)
    assert all(torch.count_nonzero(b) == 0 for b in ensemble.biases)
    assert not torch.equal(ensemble.weights[0][0], ensemble.weights[0][1])


def test_forward_equals_separate_modules():
    ensemble = MLPEnsemble.kaiming(SIZES, generators(5))
    z = torch.randn(64, 13, generator=torch.Generator().manual_seed(0))
    stacked = ensemble(z)
    for e, module in enumerate(ensemble.as_modules()):
        torch.testing.assert_close(stacked[e], module(z), rtol=1e-6, atol=1e-6)
    per_member = torch.randn(5, 7, 13, generator=torch.Generator().manual_seed(1))
    for e, module in enumerate(ensemble.as_modules()):
        torch.testing.assert_close(ensemble(per_member)[e], module(per_member[e]), rtol=1e-6, atol=1e-6)


def detached(ensemble):
    return [w.detach() for w in ensemble.weights], [b.detach() for b in ensemble.biases]


@pytest.mark.parametrize("l1_lambda", [0.0, 1e-2])
def test_hand_written_gradients_equal_autograd(l1_lambda):
    ensemble = MLPEnsemble.kaiming(SIZES, generators(3))
    g = torch.Generator().manual_seed(2)
    z, y = torch.randn(50, 13, generator=g), torch.randn(50, 8, generator=g)
    mse, weight_grads, bias_grads = ensemble_gradients(z, y, *detached(ensemble), l1_lambda)
    loss = ((ensemble(z) - y) ** 2).mean(dim=(1, 2))
    (loss + l1_lambda * ensemble.l1()).sum().backward()
    torch.testing.assert_close(mse, loss.detach())
    for hand, parameter in zip(weight_grads + bias_grads, [*ensemble.weights, *ensemble.biases], strict=True):
        torch.testing.assert_close(hand, parameter.grad, rtol=1e-5, atol=1e-7)


def test_one_ensemble_step_equals_one_step_of_separate_modules():
    """The authors' structure: one nn.Module and one Adam per instance, all on the same batch."""
    l1_lambda = 1e-3
    ensemble = MLPEnsemble.kaiming(SIZES, generators(4))
    modules = ensemble.as_modules()
    g = torch.Generator().manual_seed(3)
    batches = [(torch.randn(128, 13, generator=g), torch.randn(128, 8, generator=g)) for _ in range(3)]
    optimizer = StackedAdam(ensemble, lr=1e-3)
    for z, y in batches:
        _, weight_grads, bias_grads = ensemble_gradients(z, y, *detached(ensemble), l1_lambda)
        optimizer.step(weight_grads, bias_grads)
    for module in modules:
        adam = torch.optim.Adam(module.parameters(), lr=1e-3)
        for z, y in batches:
            weights = [p for name, p in module.named_parameters() if name.endswith("weight")]
            loss = torch.nn.functional.mse_loss(module(z), y) + l1_lambda * sum(w.abs().sum() for w in weights)
            adam.zero_grad()
            loss.backward()
            adam.step()
    for e, module in enumerate(modules):
        linears = [m for m in module if isinstance(m, torch.nn.Linear)]
        for layer, linear in enumerate(linears):
            torch.testing.assert_close(ensemble.weights[layer][e], linear.weight.detach().T, rtol=1e-5, atol=1e-6)
            torch.testing.assert_close(ensemble.biases[layer][e, 0], linear.bias.detach(), rtol=1e-5, atol=1e-6)


def test_l1_term_of_a_hand_built_network():
    weights = [torch.tensor([[[1.0, -2.0], [0.5, 0.0]]]), torch.tensor([[[-3.0], [0.25]]])]
    biases = [torch.tensor([[[10.0, -10.0]]]), torch.tensor([[[7.0]]])]
    ensemble = MLPEnsemble(weights, biases)
    assert ensemble.l1().item() == 1 + 2 + 0.5 + 0 + 3 + 0.25  # biases are not penalised
    _, weight_grads, bias_grads = ensemble_gradients(
        torch.zeros(1, 2), torch.tensor([[-3.0]]), *detached(ensemble), l1_lambda=0.5
    )
    # output = relu(b1) . w2 + b2 = 10 * -3 + 7 = -23; d(mse)/d(b2) = 2 (-23 + 3) = -40
    assert bias_grads[1].item() == pytest.approx(-40.0)
    torch.testing.assert_close(weight_grads[1], torch.tensor([[[-400.0 - 0.5], [0.0 + 0.5]]]))
    # l1 adds lambda * sign(w) to the weights' gradient only (sign(0) = 0)
    torch.testing.assert_close(weight_grads[0], torch.tensor([[[0.5, -0.5], [0.5, 0.0]]]))


def test_targets_follow_spec_section_5(smoke_train, pbm):
    x, u = smoke_train
    dt = 10.0
    ddm = training_data(x, u, dt, "ddm")
    costa = training_data(x, u, dt, "costa", pbm)
    rates = (x[:, 1:] - x[:, :-1]) / dt
    flat = np.concatenate([x, u], -1).reshape(-1, 13)
    np.testing.assert_allclose(ddm.normalisation.input_mean, flat.mean(0))
    np.testing.assert_allclose(ddm.normalisation.rate_std, rates.reshape(-1, 8).std(0, ddof=1))
    n = ddm.normalisation
    # trajectory 1, step 17, by hand
    k = 1 * (x.shape[1] - 1) + 17
    z = (np.concatenate([x[1, 17], u[1, 17]]) - n.input_mean) / n.input_std
    np.testing.assert_allclose(ddm.inputs[k].numpy(), z, rtol=1e-6)
    np.testing.assert_allclose(ddm.targets[k].numpy(), (rates[1, 17] - n.rate_mean) / n.rate_std, rtol=1e-5, atol=1e-6)
    residual = (rates[1, 17] - pbm.rhs(x[1, 17], u[1, 17])) / n.rate_std
    np.testing.assert_allclose(costa.targets[k].numpy(), residual, rtol=1e-5, atol=1e-6)
    # x2, x3, x5 are exact in the PBM: their CoSTA targets are only the RK4-vs-Euler gap
    assert np.abs(costa.targets[:, [1, 2, 4]].numpy()).max() < 1e-3
    with pytest.raises(ValueError, match="need the physics model"):
        training_data(x, u, dt, "costa")


def settings(**changes):
    base = TrainingSettings((16, 16), 1e-3, 64, 3, 2, 1e-3, None, compile=False)
    return TrainingSettings(**{**vars(base), **changes})


def test_loss_falls_on_a_small_problem(smoke_train):
    x, u = smoke_train
    data = training_data(x, u, 10.0, "ddm")
    _, losses = train_ensemble(
        data, ModelType("ddm_dense", "ddm", 0.0), settings(epochs=15), generators(2), torch.Generator().manual_seed(0)
    )
    first, last = losses[losses.epoch == 1].mse.to_numpy(), losses[losses.epoch == 15].mse.to_numpy()
    assert np.all(last < 0.5 * first), (first, last)
    assert list(losses.columns) == ["model_type", "instance", "epoch", "mse", "l1_penalty", "loss"]


def test_training_is_deterministic_and_instances_independent_of_their_number(smoke_config, smoke_train):
    x, u = smoke_train
    config = copy.deepcopy(smoke_config)
    first = train_model_type(config, "costa_sparse", x, u, replicate=0)
    second = train_model_type(config, "costa_sparse", x, u, replicate=0)
    for a, b in zip(first.ensemble.parameters(), second.ensemble.parameters(), strict=True):
        assert torch.equal(a, b)
    config["training"]["instances"] = 1
    alone = train_model_type(config, "costa_sparse", x, u, replicate=0)
    for a, b in zip(alone.ensemble.parameters(), first.ensemble.parameters(), strict=True):
        # same draws and batches; batched products of another size may round differently
        torch.testing.assert_close(a[0], b[0], rtol=1e-5, atol=1e-6)


def test_saved_instance_reloads_and_predicts_identically(smoke_config, smoke_train, tmp_path):
    x, u = smoke_train
    fitted = train_model_type(smoke_config, "costa_dense", x, u, replicate=0)
    paths = [tmp_path / f"instance{i}.pt" for i in range(2)]
    for member, path in enumerate(paths):
        save_instance(
            path, fitted.ensemble, member, fitted.model_type, fitted.normalisation, smoke_config, {"mse": 1.0}
        )
    both, second = load_models(paths), load_models(paths[1:])
    xs, us = torch.from_numpy(x[0, :50]), torch.from_numpy(u[0, :50])
    stacked = both.rhs(xs.expand(2, 50, 8), us)
    torch.testing.assert_close(second.rhs(xs.expand(1, 50, 8), us)[0], stacked[1], rtol=0, atol=0)
    n = fitted.normalisation
    z = ((np.concatenate([x[0, :50], u[0, :50]], -1) - n.input_mean) / n.input_std).astype(np.float32)
    network = fitted.ensemble(torch.from_numpy(z))[1].detach().double().numpy()
    by_hand = both.pbm.rhs(x[0, :50], u[0, :50]) + network * n.rate_std
    np.testing.assert_allclose(stacked[1].numpy(), by_hand, rtol=1e-12)


def test_pruning_zeroes_small_weights_and_sparsity_counts_them():
    ensemble = MLPEnsemble.kaiming([13, 20, 8], generators(2))
    before = sparsity(ensemble, 0.1)
    prune(ensemble, 0.1)
    after = sparsity(ensemble, 1e-12)
    np.testing.assert_array_equal(after.below_threshold, before.below_threshold)
    assert set(after.columns) >= {"instance", "layer", "weights", "below_threshold", "fraction"}
    assert after.weights.tolist() == [260, 260, 160, 160]


@pytest.mark.parametrize(
    ("override", "message"),
    [
        (
            {"training": {"model_types": {"ddm_sparse": {"target": "ddm", "l1_lambda": -1e-4}}}},
            "training.model_types.ddm_sparse.l1_lambda",
        ),
        (
            {"training": {"model_types": {"gru": {"target": "recurrent", "l1_lambda": 0}}}},
            "training.model_types.gru.target",
        ),
        ({"training": {"batch_size": 0}}, "training.batch_size"),
        ({"training": {"model_types": {"pbm": {"target": "ddm", "l1_lambda": 0}}}}, "training.model_types"),
    ],
)
def test_bad_training_config_is_named(override, message):
    with pytest.raises(ConfigError, match=message.replace(".", r"\.")):
        load_config(overrides=override)


def test_batch_larger_than_data_and_unknown_type_are_named(smoke_config, smoke_train):
    x, u = smoke_train
    config = copy.deepcopy(smoke_config)
    with pytest.raises(ValueError, match=r"unknown model type 'gru'; configured: \['costa_dense'"):
        train_model_type(config, "gru", x, u, replicate=0)
    config["training"]["batch_size"] = 10**6
    with pytest.raises(
        ValueError, match=r"training.batch_size \(1000000\) is larger than the training set \(1197 samples\)"
    ):
        train_model_type(config, "ddm_dense", x, u, replicate=0)


def test_compiled_gradients_agree_with_eager():
    """The workflow compiles the gradient step (training.compile); it must compute the same thing."""
    ensemble = MLPEnsemble.kaiming(SIZES, generators(3))
    g = torch.Generator().manual_seed(4)
    z, y = torch.randn(32, 13, generator=g), torch.randn(32, 8, generator=g)
    weights, biases = [w.detach() for w in ensemble.weights], [b.detach() for b in ensemble.biases]
    eager = ensemble_gradients(z, y, weights, biases, 1e-3)
    compiled = compiled_or_eager(ensemble_gradients)(z, y, weights, biases, 1e-3)
    torch.testing.assert_close(compiled[0], eager[0], rtol=1e-5, atol=1e-7)
    for a, b in zip(compiled[1] + compiled[2], eager[1] + eager[2], strict=True):
        torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-6)


def test_a_planted_infinite_target_stops_training_naming_type_instance_and_epoch():
    inputs = torch.randn(256, 13, generator=torch.Generator().manual_seed(0))
    targets = torch.randn(256, 8, generator=torch.Generator().manual_seed(1))
    targets[17, 3] = float("inf")
    data = TrainingData(inputs, targets, normalisation=None)
    settings = TrainingSettings((20, 20), 1e-3, 64, 3, 2, 1e-3, None)
    model_type = ModelType("costa_sparse", "costa", 1e-4)
    with pytest.raises(
        NonFiniteLossError, match=r"'costa_sparse'.*instance\(s\) \[0, 1\].*epoch 1 .*no model is saved"
    ):
        train_ensemble(data, model_type, settings, generators(2), torch.Generator().manual_seed(2))
