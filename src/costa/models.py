"""Trained networks as models of dx/dt: DDM (network alone) and CoSTA (PBM + network).

- DDM:   dx/dt = NN(z) * std(r) + mean(r)
- CoSTA: dx/dt = f_PBM(x, u) + NN(z) * std(r)

with z the standardised (x, u) and r the training set's finite-difference rates.
A model type with a ``source_bound`` clamps NN(z) to the training targets' range
widened by ``margin`` times its width on each side (the corrective source cannot
leave what the training data showed), and with ``inputs`` also clamps z to the
training inputs' range (the network is not asked to extrapolate).  A ``rate_bound``
clamps the model's dx/dt to the training rates' range, widened alike (no state moves
faster than the training data ever did).  Inside the ranges it is the plain model.
Each trained instance is saved on its own with everything needed to predict: its
weights, the normalisation, its model type and the config it came from (from which
the PBM of a CoSTA model is rebuilt).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
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
        self._bounds = self._rate_bounds = None
        if self.model_type.rate_bound is not None:
            if n.rate_low is None:
                raise ValueError(f"{self.model_type.name}: a rate bound needs the training rates' range")
            width = self.model_type.rate_bound["margin"] * (n.rate_high - n.rate_low)
            self._rate_bounds = (torch.from_numpy(n.rate_low - width), torch.from_numpy(n.rate_high + width))
        bound = self.model_type.source_bound
        if bound is not None:
            if n.target_low is None or n.input_low is None:
                raise ValueError(
                    f"{self.model_type.name}: a source bound needs the training ranges in its normalisation"
                )
            width = bound["margin"] * (n.target_high - n.target_low)
            inputs = (n.input_low, n.input_high) if bound["inputs"] else None
            self._bounds = tuple(
                None if b is None else torch.from_numpy(np.asarray(b)).float()
                for b in (*(inputs or (None, None)), n.target_low - width, n.target_high + width)
            )

    @property
    def n_members(self) -> int:
        return self.ensemble.n_members

    @torch.no_grad()
    def rhs(self, x: torch.Tensor, u: torch.Tensor) -> torch.Tensor:
        """dx/dt (E, B, 8) float64 for states x (E, B, 8) and inputs u (B, 5) or (E, B, 5)."""
        u = u.expand(x.shape[0], *u.shape[-2:]) if u.dim() == 2 else u
        z = ((torch.cat([x, u], dim=-1) - self._input_mean) / self._input_std).float()
        output = self._network(z)
        correction = output.double() * self._rate_std
        rate = correction + self._rate_mean if self.model_type.target == "ddm" else self.pbm.rhs(x, u) + correction
        return rate if self._rate_bounds is None else torch.clamp(rate, *self._rate_bounds)

    def _network(self, z: torch.Tensor) -> torch.Tensor:
        """NN(z) (E, B, 8), within the source bound if the model type has one."""
        if self._bounds is None:
            return self.ensemble(z)
        input_low, input_high, low, high = self._bounds
        if input_low is not None:
            z = torch.clamp(z, input_low, input_high)
        return torch.clamp(self.ensemble(z), low, high)


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
