"""One function per figure; each takes tidy tables and returns a matplotlib Figure."""

from .datasets import plot_datasets
from .style import save

__all__ = ["plot_datasets", "save"]
