"""The paper's colours and the one way figures are saved."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

#: tab10 colours as the paper uses them (Tpurple, Tblue, Tgreen, Torange, Tred)
MODEL_COLORS = {
    "ddm_dense": "#9467bd",
    "ddm_sparse": "#1f77b4",
    "costa_dense": "#2ca02c",
    "costa_sparse": "#ff7f0e",
    "pbm": "#d62728",
    # beyond the paper (config/beyond.yaml)
    "costa_bounded": "#8c564b",
    "costa_smooth": "#17becf",
    "discovered": "#e377c2",
}
MODEL_LABELS = {
    "ddm_dense": "DDM dense",
    "ddm_sparse": "DDM sparse",
    "costa_dense": "CoSTA dense",
    "costa_sparse": "CoSTA sparse",
    "pbm": "PBM (ablated)",
    "costa_bounded": "CoSTA bounded",
    "costa_smooth": "CoSTA smoothed targets",
    "discovered": "discovered (PBM + found law)",
}
TRAIN_COLOR = "#1f77b4"
TEST_COLOR = "#ff7f0e"
TRUTH_COLOR = "black"


def model_color(name: str) -> str:
    """The paper's colour of a model type (grey for types the paper does not have)."""
    return MODEL_COLORS.get(name, "#7f7f7f")


def model_label(name: str) -> str:
    return MODEL_LABELS.get(name, name)


# Fixed metadata keep PDFs byte-identical for identical figures.
_METADATA = {"png": {"Software": None}, "pdf": {"CreationDate": None, "Producer": None, "Creator": None}}


def save(fig: plt.Figure, *paths: str | Path, dpi: int = 150) -> None:
    """Save a figure to each path (format from the suffix) and close it."""
    for path in paths:
        suffix = Path(path).suffix[1:].lower()
        fig.savefig(path, dpi=dpi, bbox_inches="tight", metadata=_METADATA.get(suffix))
    plt.close(fig)
