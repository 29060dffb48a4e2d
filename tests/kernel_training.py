"""Train networks in a fresh process, under the kernels its environment sets, and print
the per-epoch losses and a hash of the weights as JSON (run by tests/test_kernels.py).

    python tests/kernel_training.py small eager|compiled   # 4 instances at the paper's layer sizes, synthetic data
    python tests/kernel_training.py smoke                  # the smoke config's four model types
"""

from __future__ import annotations

import hashlib
import json
import sys

import torch

from costa import seeds
from costa.config import load_config
from costa.data import arrays
from costa.datasets import simulate_split
from costa.kernels import kernel_provenance
from costa.train import ModelType, TrainingData, TrainingSettings, train_ensemble, train_model_type

CONFIGS = ("config/config.yaml", "config/smoke.yaml")


def weights_hash(ensembles) -> str:
    """sha256 of every weight and bias of the ensembles, in order, as float32 bytes."""
    digest = hashlib.sha256()
    for ensemble in ensembles:
        for tensor in (*ensemble.weights, *ensemble.biases):
            digest.update(tensor.detach().contiguous().numpy().tobytes())
    return digest.hexdigest()


def small(compiled: bool) -> dict:
    """4 instances of [13, 20, 20, 20, 20, 8], 4 epochs on 4096 synthetic samples."""
    g = torch.Generator().manual_seed(0)
    inputs = torch.randn(4096, 13, generator=g)
    targets = torch.tanh(inputs[:, :8] * inputs[:, 5:]) + 0.1 * torch.randn(4096, 8, generator=g)
    settings = TrainingSettings((20, 20, 20, 20), 1e-3, 128, 4, 4, 1e-3, None, compiled)
    init = [seeds.torch_generator(1, 0, "init", i) for i in range(settings.instances)]
    ensemble, losses = train_ensemble(
        TrainingData(inputs, targets, None), ModelType("ddm_sparse", "ddm", 1e-4), settings, init,
        seeds.torch_generator(1, 0, "shuffle"),
    )  # fmt: skip
    return {"mse": losses.mse.tolist(), "hash": weights_hash([ensemble])}


def smoke() -> dict:
    """The smoke config's four model types trained on its simulated training set."""
    config = load_config(*CONFIGS)
    x, u = arrays(simulate_split(config, "train", 0)[0])
    fitted = [train_model_type(config, name, x, u, 0) for name in config["training"]["model_types"]]
    return {"mse": [m for f in fitted for m in f.losses.mse], "hash": weights_hash([f.ensemble for f in fitted])}


if __name__ == "__main__":
    torch.set_num_threads(1)
    result = small(sys.argv[2] == "compiled") if sys.argv[1] == "small" else smoke()
    print(json.dumps({**result, **kernel_provenance()}))
