"""training.compile without a working C++ compiler: one warning, then the eager step's numbers."""

from __future__ import annotations

import warnings

import pytest
import torch

from costa import seeds
from costa.train import CompileFallbackWarning, ModelType, TrainingSettings, train_ensemble, training_data


def _train(data, compile: bool):
    settings = TrainingSettings((16, 16), 1e-3, 64, 2, 2, 1e-3, None, compile=compile)
    init = [seeds.torch_generator(1, 0, "fallback", i) for i in range(2)]
    return train_ensemble(data, ModelType("ddm_dense", "ddm", 0.0), settings, init, torch.Generator().manual_seed(0))


def test_without_a_compiler_training_falls_back_to_eager_with_one_warning(smoke_train):
    import torch._dynamo
    import torch._inductor.config as inductor

    data = training_data(*smoke_train, 10.0, "ddm")
    torch._dynamo.reset()  # no compiled step from another test may be reused
    try:
        with (
            inductor.patch({"cpp.cxx": (None, "/nonexistent/c++"), "fx_graph_cache": False}),
            warnings.catch_warnings(record=True) as caught,
        ):
            warnings.simplefilter("always")
            fallback, fallback_losses = _train(data, compile=True)
    finally:
        torch._dynamo.reset()
    raised = [w for w in caught if issubclass(w.category, CompileFallbackWarning)]
    assert len(raised) == 1, [str(w.message) for w in caught]
    assert "training eagerly instead" in str(raised[0].message)
    eager, eager_losses = _train(data, compile=False)
    for a, b in zip(fallback.parameters(), eager.parameters(), strict=True):
        assert torch.equal(a, b)
    assert fallback_losses.equals(eager_losses)


def test_other_errors_are_not_swallowed():
    from costa.train import compiled_or_eager

    def broken(x):
        raise KeyError("not a compiler problem")

    torch._dynamo.reset()
    with pytest.raises(KeyError, match="not a compiler problem"):
        compiled_or_eager(broken)(torch.ones(2))
