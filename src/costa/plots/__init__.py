"""One function per figure; each takes tidy tables and returns a matplotlib Figure."""

from .datasets import plot_datasets
from .style import save
from .training import plot_training_curves

__all__ = ["plot_datasets", "plot_training_curves", "save"]
