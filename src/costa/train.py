"""Training the DDM and CoSTA networks (docs/model.md §5).

Inputs are the 13 values (x_k, u_k), standardised with the training set's mean and
unbiased std (over all samples, as ``alu_dataset.py``).  With the finite-difference
rate r_k = (x_{k+1} - x_k)/dt, the targets are

- DDM:   (r_k - mean(r)) / std(r)
- CoSTA: (r_k - f_PBM(x_k, u_k)) / std(r)   (no mean subtracted)

as published.  A model type may instead denoise its targets (``savgol``): the rates
r and the PBM's rates f_PBM are each smoothed along time, trajectory by trajectory,
by a Savitzky-Golay filter, so that the CoSTA target is the smoothed residual
SG(r - f_PBM) (linear, so SG(r) - SG(f_PBM)) and the statistics mean(r), std(r) are
those of SG(r).  Smoothing the residual rather than the states keeps the steps that
the inputs cause (a feed impulse) out of the filter: they are in both r and f_PBM.
A model type may also bound its corrective source (``source_bound``) or its whole
rate (``rate_bound``) when forecasting (:mod:`costa.models`); training is the same,
and the training set's ranges of the standardised inputs and targets and of the
rates are stored with every model.

The loss of member e is MSE_e + lambda * sum|W_e| (weights only).  All instances of
a type see the same mini-batches (as in the authors' notebook) and differ by their
initialisation; Adam runs once over the stacked tensors, which is the per-instance
Adam exactly because each member's loss enters the total as a sum.
"""

from __future__ import annotations

import logging
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields

import numpy as np
import pandas as pd
import torch
from scipy.signal import savgol_filter

from . import seeds
from .ensemble import MLPEnsemble, StackedAdam, ensemble_gradients
from .physics import CellModel, model_from_config
from .variables import INPUTS, STATES

__all__ = [
    "CompileFallbackWarning",
    "FittedType",
    "ModelType",
    "NonFiniteLossError",
    "Normalisation",
    "TrainingData",
    "TrainingSettings",
    "prune",
    "smooth_in_time",
    "sparsity",
    "train_ensemble",
    "train_model_type",
    "training_data",
]

TARGETS = ("ddm", "costa")


class NonFiniteLossError(RuntimeError):
    """A training loss turned NaN or infinite: the networks are broken and must not be saved."""


class CompileFallbackWarning(RuntimeWarning):
    """``training.compile`` is on but the step cannot be compiled here (no working C++ compiler)."""


def vector_width_option() -> dict[str, int]:
    """Inductor's ``cpp.simdlen`` set to the vector width [bits] of the kernels picked here.

    torch 2.13's compiled-graph cache does not key its entries on the vector ISA that
    ``ATEN_CPU_CAPABILITY`` picks: a step compiled under AVX-512 (16 floats a vector) and
    loaded under AVX2 (8) is rebuilt from source that strides by 16 over 8-wide vectors,
    so half of each fused bias-and-ReLU and bias-gradient kernel is never written and the
    loss turns NaN within a few epochs.  An explicit ``cpp.simdlen`` is part of the cache
    key, so each ISA gets its own entries (docs/notes/2026-11-26-avx2-nan.md).
    """
    from torch._inductor.cpu_vec_isa import pick_vec_isa

    isa = pick_vec_isa()
    return {"cpp.simdlen": isa.bit_width()} if isa else {}


def compiled_or_eager(fn: Callable) -> Callable:
    """``fn`` compiled with ``torch.compile``, or ``fn`` itself after one warning if compiling fails.

    Inductor builds C++ kernels at the first call; without a working C++ compiler
    that call raises.  The step is then run eagerly from that first call on: a
    gradient computation has no side effects, so the numbers are those of
    ``training.compile: false``.
    """
    from torch._dynamo.exc import BackendCompilerFailed
    from torch._inductor.exc import CppCompileError, InvalidCxxCompiler

    compiled = current = None  # built at the first call: picking the vector ISA needs the compiler too

    def call(*args):
        nonlocal compiled, current
        if current is compiled:
            try:
                compiled = current = compiled or torch.compile(fn, dynamic=False, options=vector_width_option())
                return compiled(*args)
            except (BackendCompilerFailed, InvalidCxxCompiler, CppCompileError) as error:
                inner = getattr(error, "inner_exception", error)
                reason = f"{type(inner).__name__}: {(str(inner).strip().splitlines() or [''])[0]}"
                warnings.warn(
                    f"training.compile: torch.compile cannot build the training step here ({reason[:300]}); "
                    "training eagerly instead (the same numbers as training.compile: false, about 1.6x slower). "
                    "Install a C++ compiler (g++ or clang++) to compile, or set training.compile: false.",
                    CompileFallbackWarning,
                    stacklevel=2,
                )
                current = fn
        return current(*args)

    return call


@dataclass(frozen=True)
class ModelType:
    """One of the compared model types: its target, its l1 weight and two options.

    ``savgol`` ({window, order}, or None for the published forward differences)
    smooths the targets; ``source_bound`` ({margin, inputs}, or None) bounds the
    network's output, when forecasting, to the training targets' range widened by
    ``margin`` times its width on each side, and with ``inputs`` also clamps the
    standardised inputs to the training set's range; ``rate_bound`` ({margin}, or
    None) bounds the model's dx/dt to the training rates' range, widened alike.
    """

    name: str
    target: str
    l1_lambda: float
    savgol: Mapping | None = None
    source_bound: Mapping | None = None
    rate_bound: Mapping | None = None

    def __post_init__(self):
        if self.target not in TARGETS:
            raise ValueError(f"model type {self.name!r}: unknown target {self.target!r}; known: {TARGETS}")
        if self.l1_lambda < 0:
            raise ValueError(f"model type {self.name!r}: l1_lambda must be >= 0, got {self.l1_lambda}")
        if self.savgol is not None and not 0 <= self.savgol["order"] < self.savgol["window"]:
            raise ValueError(f"model type {self.name!r}: savgol.order must be below savgol.window, got {self.savgol}")


@dataclass(frozen=True)
class TrainingSettings:
    """Architecture and optimisation settings shared by all model types."""

    hidden_layers: tuple[int, ...]
    learning_rate: float
    batch_size: int
    epochs: int
    instances: int
    sparsity_threshold: float
    prune_threshold: float | None
    compile: bool = False

    @classmethod
    def from_config(cls, training: Mapping) -> TrainingSettings:
        return cls(
            hidden_layers=tuple(training["hidden_layers"]),
            learning_rate=float(training["learning_rate"]),
            batch_size=int(training["batch_size"]),
            epochs=int(training["epochs"]),
            instances=int(training["instances"]),
            sparsity_threshold=float(training["sparsity_threshold"]),
            prune_threshold=training["prune_threshold"],
            compile=bool(training["compile"]),
        )

    def sizes(self, n_in: int = 13, n_out: int = 8) -> list[int]:
        return [n_in, *self.hidden_layers, n_out]


@dataclass(frozen=True)
class Normalisation:
    """Training-set statistics (float64): inputs (13,) and rates (8,); the ranges
    (minimum, maximum) of the standardised inputs (13,) and targets (8,) and of the
    rates (8,), which only a bounded model type (``source_bound``, ``rate_bound``) needs."""

    input_mean: np.ndarray
    input_std: np.ndarray
    rate_mean: np.ndarray
    rate_std: np.ndarray
    input_low: np.ndarray | None = None
    input_high: np.ndarray | None = None
    target_low: np.ndarray | None = None
    target_high: np.ndarray | None = None
    rate_low: np.ndarray | None = None
    rate_high: np.ndarray | None = None

    def as_dict(self) -> dict[str, list[float]]:
        return {k: np.asarray(v).tolist() for k, v in vars(self).items() if v is not None}

    @classmethod
    def from_dict(cls, d: Mapping) -> Normalisation:
        return cls(**{f.name: np.asarray(d[f.name], dtype=np.float64) for f in fields(cls) if f.name in d})


@dataclass(frozen=True)
class TrainingData:
    """Standardised inputs (N, 13) and targets (N, 8) in float32, and their statistics."""

    inputs: torch.Tensor
    targets: torch.Tensor
    normalisation: Normalisation


def smooth_in_time(values: np.ndarray, savgol: Mapping | None) -> np.ndarray:
    """values (n, K, ...) smoothed along K, trajectory by trajectory, by a Savitzky-Golay
    filter of ``savgol`` = {window, order}; unchanged for None."""
    if savgol is None:
        return values
    window, order = int(savgol["window"]), int(savgol["order"])
    if window > values.shape[1]:
        raise ValueError(f"savgol.window ({window}) is longer than the trajectories' {values.shape[1]} rates")
    return savgol_filter(values, window, order, axis=1)


def training_data(
    x: np.ndarray, u: np.ndarray, dt: float, target: str, pbm: CellModel | None = None, savgol: Mapping | None = None
) -> TrainingData:
    """Inputs and targets from trajectories x (n, K, 8), u (n, K, 5) sampled every dt [s].

    ``savgol`` ({window, order}) smooths the targets (module docstring); None keeps
    the published forward differences.
    """
    if target not in TARGETS:
        raise ValueError(f"unknown target {target!r}; known: {TARGETS}")
    samples = np.concatenate([x, u], axis=-1)
    flat = samples.reshape(-1, 13)
    input_mean, input_std = flat.mean(axis=0), flat.std(axis=0, ddof=1)
    rates = smooth_in_time((x[:, 1:] - x[:, :-1]) / dt, savgol).reshape(-1, 8)
    rate_mean, rate_std = rates.mean(axis=0), rates.std(axis=0, ddof=1)
    constant = [name for name, std in zip((*STATES, *INPUTS), input_std, strict=True) if std == 0]
    constant += [f"d{name}/dt" for name, std in zip(STATES, rate_std, strict=True) if std == 0]
    if constant:
        raise ValueError(f"{constant} do not vary in the training set, so they cannot be standardised")
    inputs = (samples[:, :-1].reshape(-1, 13) - input_mean) / input_std
    if target == "ddm":
        targets = (rates - rate_mean) / rate_std
    else:
        if pbm is None:
            raise ValueError("CoSTA targets need the physics model (pbm)")
        with np.errstate(all="ignore"):
            physics = smooth_in_time(pbm.rhs(x[:, :-1], u[:, :-1]), savgol).reshape(-1, 8)
        targets = (rates - physics) / rate_std
    inputs, targets = inputs.astype(np.float32), targets.astype(np.float32)
    ranges = [a.astype(np.float64) for a in (inputs.min(0), inputs.max(0), targets.min(0), targets.max(0))]
    return TrainingData(
        torch.from_numpy(inputs),
        torch.from_numpy(targets),
        Normalisation(input_mean, input_std, rate_mean, rate_std, *ranges, rates.min(0), rates.max(0)),
    )


def train_ensemble(
    data: TrainingData,
    model_type: ModelType,
    settings: TrainingSettings,
    init_generators: Sequence[torch.Generator],
    shuffle_generator: torch.Generator,
    log: logging.Logger | None = None,
) -> tuple[MLPEnsemble, pd.DataFrame]:
    """Train one model type's instances together; returns them and the per-epoch losses.

    The loss table has one row per instance and epoch: the batch-size weighted mean
    MSE over the epoch, the l1 penalty lambda * sum|W| at its end, and their sum.
    """
    n = data.inputs.shape[0]
    if settings.batch_size > n:
        raise ValueError(f"training.batch_size ({settings.batch_size}) is larger than the training set ({n} samples)")
    ensemble = MLPEnsemble.kaiming(settings.sizes(), init_generators)
    optimizer = StackedAdam(ensemble, settings.learning_rate)
    weights, biases = [w.detach() for w in ensemble.weights], [b.detach() for b in ensemble.biases]
    # Full batches run compiled (one shape, one compilation); the last, shorter batch of
    # an epoch runs eagerly rather than triggering a second compilation.
    compiled = compiled_or_eager(ensemble_gradients) if settings.compile else ensemble_gradients
    rows = []
    started = time.perf_counter()
    for epoch in range(1, settings.epochs + 1):
        order = torch.randperm(n, generator=shuffle_generator)
        inputs, targets = data.inputs.index_select(0, order), data.targets.index_select(0, order)
        squared = torch.zeros(ensemble.n_members, dtype=torch.float64)
        for start in range(0, n, settings.batch_size):
            stop = min(start + settings.batch_size, n)
            gradients = compiled if stop - start == settings.batch_size else ensemble_gradients
            mse, weight_grads, bias_grads = gradients(
                inputs[start:stop], targets[start:stop], weights, biases, model_type.l1_lambda
            )
            optimizer.step(weight_grads, bias_grads)
            squared += mse.double() * (stop - start)
        with torch.no_grad():
            penalty = model_type.l1_lambda * ensemble.l1().double()
        stop_if_not_finite(squared + penalty, model_type, epoch, settings.compile)
        for member in range(ensemble.n_members):
            mse_epoch = float(squared[member]) / n
            rows.append((member, epoch, mse_epoch, float(penalty[member]), mse_epoch + float(penalty[member])))
        if log and (epoch % 10 == 0 or epoch == settings.epochs):
            log.info(
                "epoch %d: mean mse %.4g (%.1f s)", epoch, float(squared.mean()) / n, time.perf_counter() - started
            )
    losses = pd.DataFrame(rows, columns=["instance", "epoch", "mse", "l1_penalty", "loss"])
    losses.insert(0, "model_type", model_type.name)
    return ensemble, losses


def stop_if_not_finite(loss: torch.Tensor, model_type: ModelType, epoch: int, compiled: bool) -> None:
    """Raise :class:`NonFiniteLossError` naming the type, the instances and the epoch if
    any instance's summed epoch loss (E,) is NaN or infinite."""
    broken = torch.nonzero(~torch.isfinite(loss)).flatten().tolist()
    if not broken:
        return
    cause = "a non-finite value in the training data or its targets, a learning rate too large for the data" + (
        ", or a miscompiled training step (set training.compile: false to test)" if compiled else ""
    )
    raise NonFiniteLossError(
        f"training {model_type.name!r}: the loss of instance(s) {broken} is not finite at epoch {epoch} "
        f"({float(loss[broken[0]])}); no model is saved. Likely cause: {cause}."
    )


@torch.no_grad()
def prune(ensemble: MLPEnsemble, threshold: float) -> None:
    """Magnitude pruning: set weights with |w| < threshold to zero (biases untouched)."""
    for w in ensemble.weights:
        w.masked_fill_(w.abs() < threshold, 0.0)


@torch.no_grad()
def sparsity(ensemble: MLPEnsemble, threshold: float) -> pd.DataFrame:
    """Per instance and layer: how many weights have |w| below ``threshold``."""
    rows = []
    for layer, w in enumerate(ensemble.weights, start=1):
        below = (w.abs() < threshold).sum(dim=(1, 2))
        for member in range(ensemble.n_members):
            rows.append((member, layer, w.shape[1] * w.shape[2], int(below[member])))
    table = pd.DataFrame(rows, columns=["instance", "layer", "weights", "below_threshold"])
    table["fraction"] = table["below_threshold"] / table["weights"]
    table["threshold"] = threshold
    return table


@dataclass(frozen=True)
class FittedType:
    """Everything training one model type produces."""

    model_type: ModelType
    ensemble: MLPEnsemble
    normalisation: Normalisation
    losses: pd.DataFrame
    sparsity: pd.DataFrame


def train_model_type(
    config: Mapping, name: str, x: np.ndarray, u: np.ndarray, replicate: int, log: logging.Logger | None = None
) -> FittedType:
    """Train the instances of model type ``name`` as the config says, on trajectories x, u.

    Instance i is initialised from stream ("init/<name>", i) and all instances share
    the mini-batch order of stream ("shuffle/<name>"), so instance i gets the same
    draws however many instances are trained (its weights then agree to float32
    rounding: batched products of another size may round differently).
    """
    training = config["training"]
    if name not in training["model_types"]:
        raise ValueError(f"unknown model type {name!r}; configured: {sorted(training['model_types'])}")
    model_type = ModelType(name, **training["model_types"][name])
    settings = TrainingSettings.from_config(training)
    pbm = model_from_config(config["physics"])[1]
    data = training_data(x, u, config["simulation"]["dt_s"], model_type.target, pbm, model_type.savgol)
    init = [seeds.torch_generator(config["seed"], replicate, f"init/{name}", i) for i in range(settings.instances)]
    shuffle = seeds.torch_generator(config["seed"], replicate, f"shuffle/{name}")
    ensemble, losses = train_ensemble(data, model_type, settings, init, shuffle, log)
    if settings.prune_threshold is not None:
        prune(ensemble, settings.prune_threshold)
    return FittedType(model_type, ensemble, data.normalisation, losses, sparsity(ensemble, settings.sparsity_threshold))
