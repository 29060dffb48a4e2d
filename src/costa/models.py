"""Trained networks as models of dx/dt: DDM (network alone) and CoSTA (PBM + network).

- DDM:   dx/dt = NN(z) * std(r) + mean(r)
- CoSTA: dx/dt = f_PBM(x, u) + NN(z) * std(r)

with z the standardised (x, u) and r the training set's finite-difference rates.
Each trained instance is saved on its own with everything needed to predict: its
weights, the normalisation, its model type and the config it came from (from which
the PBM of a CoSTA model is rebuilt).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch

from .ensemble import MLPEnsemble
from .physics import CellModel, model_from_config
from .train import ModelType, Normalisation

__all__ = ["NetworkModel", "load_models", "save_instance"]

FORMAT = "costa.network-instance/1"


@dataclass
class NetworkModel:
    """E trained instances of one model type, predicting dx/dt for each member."""

    model_type: ModelType
    ensemble: MLPEnsemble
    normalisation: Normalisation
    pbm: CellModel | None
    config: Mapping[str, Any]

    def __post_init__(self):
        if self.model_type.target == "costa" and self.pbm is None:
            raise ValueError(f"{self.model_type.name}: a CoSTA model needs its PBM")
        n = self.normalisation
        self._input_mean, self._input_std = torch.from_numpy(n.input_mean), torch.from_numpy(n.input_std)
        self._rate_mean, self._rate_std = torch.from_numpy(n.rate_mean), torch.from_numpy(n.rate_std)

    @property
    def n_members(self) -> int:
        return self.ensemble.n_members

    @torch.no_grad()
    def rhs(self, x: torch.Tensor, u: torch.Tensor) -> torch.Tensor:
        """dx/dt (E, B, 8) float64 for states x (E, B, 8) and inputs u (B, 5) or (E, B, 5)."""
        u = u.expand(x.shape[0], *u.shape[-2:]) if u.dim() == 2 else u
        z = ((torch.cat([x, u], dim=-1) - self._input_mean) / self._input_std).float()
        correction = self.ensemble(z).double() * self._rate_std
        if self.model_type.target == "ddm":
            return correction + self._rate_mean
        return self.pbm.rhs(x, u) + correction


def save_instance(
    path: str | Path,
    ensemble: MLPEnsemble,
    member: int,
    model_type: ModelType,
    normalisation: Normalisation,
    config: Mapping[str, Any],
    summary: Mapping[str, float],
) -> None:
    """Save member ``member`` alone, with its normalisation, type, config and training summary."""
    single = ensemble.select([member])
    torch.save(
        {
            "format": FORMAT,
            "model_type": vars(model_type),
            "instance": member,
            "weights": [w.detach()[0].clone() for w in single.weights],
            "biases": [b.detach()[0].clone() for b in single.biases],
            "normalisation": normalisation.as_dict(),
            "config": dict(config),
            "summary": dict(summary),
        },
        path,
    )


def _read(path: str | Path) -> dict:
    artifact = torch.load(path, weights_only=True)
    if artifact.get("format") != FORMAT:
        raise ValueError(f"{path}: not a saved network instance (format {artifact.get('format')!r})")
    return artifact


def load_models(paths: Sequence[str | Path]) -> NetworkModel:
    """Instances of one model type (one or more ``instance<i>.pt`` files) stacked into one :class:`NetworkModel`.

    The files must share their model type, normalisation and config (those of one
    training run).  ``model.rhs(x, u)`` then gives dx/dt (E, B, 8) for states x
    (E, B, 8) and inputs u (B, 5), one row per instance; a CoSTA model rebuilds its
    physics model from the stored config.  ``results/README.md`` shows an example.
    """
    artifacts = [_read(p) for p in paths]
    first = artifacts[0]
    for path, other in zip(paths[1:], artifacts[1:], strict=True):
        for key in ("model_type", "normalisation", "config"):
            if other[key] != first[key]:
                raise ValueError(f"{path}: its {key} differs from {paths[0]}'s; only instances of one type stack")
    ensemble = MLPEnsemble(
        [torch.stack([a["weights"][i] for a in artifacts]) for i in range(len(first["weights"]))],
        [torch.stack([a["biases"][i] for a in artifacts]) for i in range(len(first["biases"]))],
    )
    model_type = ModelType(**first["model_type"])
    pbm = model_from_config(first["config"]["physics"])[1] if model_type.target == "costa" else None
    return NetworkModel(model_type, ensemble, Normalisation.from_dict(first["normalisation"]), pbm, first["config"])
