"""One function per figure; each takes tidy tables and returns a matplotlib Figure."""

from .benchmark import plot_recall_by_signal
from .beyond import plot_noise_study
from .datasets import plot_datasets
from .discovery import plot_discovery
from .line import plot_line
from .replicates import plot_replicate_blowups
from .results import plot_blowups, plot_error_violins, plot_rolling_forecast
from .style import save
from .training import plot_training_curves

__all__ = [
    "plot_blowups",
    "plot_datasets",
    "plot_discovery",
    "plot_error_violins",
    "plot_line",
    "plot_noise_study",
    "plot_recall_by_signal",
    "plot_replicate_blowups",
    "plot_rolling_forecast",
    "plot_training_curves",
    "save",
]
