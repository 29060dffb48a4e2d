"""Training speed: the stacked ensemble against the authors' one-module-per-instance loop.

Runs, in one process and one thread (as a Snakemake job with ``threads: 1``), a few
hundred mini-batches of the paper's training problem (CoSTA sparse) with

  (a) the stacked ensemble, hand-written backward compiled by torch.compile, torch's
      fused Adam fed the gradients directly: what the workflow runs (training.compile: true);
  (b) the same, eager (training.compile: false);
  (c) the same ensemble with autograd's backward;
  (d) the authors' structure as in their notebook: a shuffling DataLoader, and for
      each mini-batch one train step per instance (its own nn.Module and Adam, MSE
      plus l1 over the weights, backward, step, zero_grad, loss.item());
  (e) the loop of (d) without the DataLoader (batches sliced from a tensor);

and prints seconds per epoch (extrapolated from the timed batches), the speed-up over
(d) and (e), and the achieved FLOP rate against a large matmul timed in the same run.

    python benchmarks/train_speed.py [--config config/config.yaml] [--batches 300]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
import torch
from torch.utils.data import DataLoader, TensorDataset

from costa import seeds
from costa.config import load_config
from costa.data import arrays
from costa.datasets import simulate_split
from costa.ensemble import MLPEnsemble, StackedAdam, ensemble_gradients
from costa.physics import model_from_config
from costa.train import TrainingSettings, compiled_or_eager, training_data


def time_batches(step, inputs, targets, batch_size: int, batches: int) -> float:
    """Seconds per mini-batch of ``step(z, y)`` over ``batches`` batches (after 20 warm-up)."""
    for i in range(20):
        step(inputs[i * batch_size : (i + 1) * batch_size], targets[i * batch_size : (i + 1) * batch_size])
    started = time.perf_counter()
    for i in range(batches):
        step(inputs[i * batch_size : (i + 1) * batch_size], targets[i * batch_size : (i + 1) * batch_size])
    return (time.perf_counter() - started) / batches


def matmul_gflops(n: int = 2048, repeats: int = 5) -> float:
    a, b = torch.randn(n, n), torch.randn(n, n)
    a @ b
    started = time.perf_counter()
    for _ in range(repeats):
        a @ b
    return 2 * n**3 * repeats / (time.perf_counter() - started) / 1e9


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--config", nargs="*", default=[])
    parser.add_argument("--batches", type=int, default=300)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)

    config = load_config(*args.config) if args.config else load_config()
    settings = TrainingSettings.from_config(config["training"])
    x, u = arrays(simulate_split(config, "train", replicate=0)[0])
    data = training_data(x, u, config["simulation"]["dt_s"], "costa", model_from_config(config["physics"])[1])
    order = torch.randperm(data.inputs.shape[0], generator=torch.Generator().manual_seed(0))
    inputs, targets = data.inputs[order], data.targets[order]
    n, batch, members = inputs.shape[0], settings.batch_size, settings.instances
    batches_per_epoch = math.ceil(n / batch)
    batches = min(args.batches, batches_per_epoch - 20)
    l1_lambda = 1e-4
    generators = [seeds.torch_generator(0, 0, "bench", i) for i in range(members)]

    def stacked_step_factory(compiled: bool):
        ensemble = MLPEnsemble.kaiming(settings.sizes(), generators)
        adam = StackedAdam(ensemble, settings.learning_rate)
        weights, biases = [w.detach() for w in ensemble.weights], [b.detach() for b in ensemble.biases]
        gradients = compiled_or_eager(ensemble_gradients) if compiled else ensemble_gradients

        def step(z, y):
            _, weight_grads, bias_grads = gradients(z, y, weights, biases, l1_lambda)
            adam.step(weight_grads, bias_grads)

        return step

    autograd = MLPEnsemble.kaiming(settings.sizes(), generators)
    autograd_adam = torch.optim.Adam(autograd.parameters(), lr=settings.learning_rate, fused=True)

    def autograd_step(z, y):
        loss = ((autograd(z) - y) ** 2).mean(dim=(1, 2)) + l1_lambda * autograd.l1()
        autograd_adam.zero_grad(set_to_none=True)
        loss.sum().backward()
        autograd_adam.step()

    modules = MLPEnsemble.kaiming(settings.sizes(), generators).as_modules()
    module_adams = [torch.optim.Adam(m.parameters(), lr=settings.learning_rate) for m in modules]
    loss_fn = torch.nn.MSELoss()

    def authors_step(z, y):
        for module, adam in zip(modules, module_adams, strict=True):
            module.train()
            penalty = sum(p.norm(1) for name, p in module.named_parameters() if name.endswith("weight"))
            loss = loss_fn(y, module(z)) + l1_lambda * penalty
            loss.backward()
            adam.step()
            adam.zero_grad()
            loss.item()

    def authors_epoch_part(batches: int) -> float:
        loader = DataLoader(TensorDataset(data.inputs, data.targets), batch_size=batch, shuffle=True)
        started = time.perf_counter()
        for i, (z, y) in enumerate(loader):
            if i == batches:
                break
            authors_step(z, y)
        return (time.perf_counter() - started) / batches

    authors_batches = max(20, batches // 5)
    compiled_step = stacked_step_factory(compiled=True)
    compiled_step(inputs[:batch], targets[:batch])  # compile outside the timing
    timings = {
        "(a) stacked, compiled hand-written backward": time_batches(compiled_step, inputs, targets, batch, batches),
        "(b) stacked, eager hand-written backward": time_batches(
            stacked_step_factory(compiled=False), inputs, targets, batch, batches
        ),
        "(c) stacked, autograd backward": time_batches(autograd_step, inputs, targets, batch, batches),
        "(d) authors: DataLoader + module and Adam each": authors_epoch_part(authors_batches),
        "(e) authors' module loop without DataLoader": time_batches(
            authors_step, inputs, targets, batch, authors_batches
        ),
    }
    flops_per_batch = (
        3 * 2 * batch * members * sum(a * b for a, b in zip(settings.sizes()[:-1], settings.sizes()[1:], strict=False))
    )
    peak = matmul_gflops()
    authors = timings["(d) authors: DataLoader + module and Adam each"]
    loop = timings["(e) authors' module loop without DataLoader"]

    print(f"training problem: {n} samples, batch {batch}, {members} instances, sizes {settings.sizes()}, "
          f"{batches_per_epoch} batches/epoch, {torch.get_num_threads()} thread(s)")  # fmt: skip
    print(f"{'layout':48s} {'ms/batch':>9s} {'s/epoch':>8s} {'vs (d)':>7s} {'vs (e)':>7s} {'GFLOP/s':>8s}")
    for name, seconds in timings.items():
        print(
            f"{name:48s} {seconds * 1e3:9.3f} {seconds * batches_per_epoch:8.2f} "
            f"{authors / seconds:6.1f}x {loop / seconds:6.1f}x {flops_per_batch / seconds / 1e9:8.2f}"
        )
    workflow = timings["(a) stacked, compiled hand-written backward"]
    types = len(config["training"]["model_types"])
    print(f"2048x2048 float32 matmul: {peak:.1f} GFLOP/s; the workflow layout reaches "
          f"{flops_per_batch / workflow / 1e9 / peak:.1%} of it")  # fmt: skip
    print(f"estimated training of {types} types x {members} instances, {settings.epochs} epochs, "
          f"2 jobs in parallel: {np.ceil(types / 2) * workflow * batches_per_epoch * settings.epochs / 60:.1f} min")  # fmt: skip


if __name__ == "__main__":
    main()
