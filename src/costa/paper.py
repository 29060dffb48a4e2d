"""What the paper reports (read off its figures; docs/model.md §7) and earlier faithful runs."""

from __future__ import annotations

import pandas as pd

__all__ = ["beside_the_paper", "paper_blowups", "paper_median_error", "reference_runs", "reference_short_median"]

_TYPES = ("ddm_dense", "ddm_sparse", "costa_dense", "costa_sparse", "pbm")

# Blow-ups out of 1000 rollouts (PBM: out of 100), read off the paper's bar chart.
# None where the figure gives no number; the PBM's "0-1" is stored as its upper end.
_BLOWUPS = {
    "short": (0, 0, 0, 0, 0),
    "medium": (120, 11, 9, 0, 1),
    "long": (275, 90, 52, 34, 1),
}

# Median AN-RFMSE read off the violins (log scale): approximate, short and long only.
_MEDIAN = {
    "short": (0.02, 0.02, 0.005, 0.005, 0.1),
    "long": (0.3, 0.3, 0.05, 0.05, 0.2),
}

# Three faithful runs of the authors' settings with other seeds (docs/model.md §7): long-window
# blow-ups, and the short-window median AN-RFMSE ranges.
_RUNS_LONG = ((322, 124, 43, 54, 5), (229, 184, 111, 51, 0), (359, 310, 67, 20, 3))
_RUNS_SHORT_MEDIAN = {"ddm": (0.012, 0.031), "costa": (0.005, 0.007), "pbm": (0.20, 0.21)}


def paper_blowups() -> pd.DataFrame:
    """model_type, window, paper_blowups, out_of."""
    rows = [
        (model, window, count, 100 if model == "pbm" else 1000)
        for window, counts in _BLOWUPS.items()
        for model, count in zip(_TYPES, counts, strict=True)
    ]
    return pd.DataFrame(rows, columns=["model_type", "window", "paper_blowups", "out_of"])


def paper_median_error() -> pd.DataFrame:
    """model_type, window, paper_median (approximate)."""
    rows = [(m, w, v) for w, values in _MEDIAN.items() for m, v in zip(_TYPES, values, strict=True)]
    return pd.DataFrame(rows, columns=["model_type", "window", "paper_median"])


def reference_runs() -> pd.DataFrame:
    """Long-window blow-ups of the three faithful reference runs: run, model_type, blowups."""
    rows = [(run, m, c) for run, counts in enumerate(_RUNS_LONG, 1) for m, c in zip(_TYPES, counts, strict=True)]
    return pd.DataFrame(rows, columns=["run", "model_type", "blowups"])


def reference_short_median(model: str) -> tuple[float, float]:
    """The range of short-window median AN-RFMSE over the reference runs."""
    return _RUNS_SHORT_MEDIAN["pbm" if model == "pbm" else model.split("_")[0]]


def beside_the_paper(coded: pd.DataFrame) -> pd.DataFrame:
    """A run's summary (coded definition, costa.summary.summary_table) beside the paper's numbers.

    Columns: model, window, rollouts, blow-ups and median AN-RFMSE with their 95 %
    intervals, and the paper's blow-ups and median (read off its figures; blank where
    it shows none).
    """
    from .plots.style import model_label
    from .summary import with_interval

    table = coded.merge(paper_blowups(), on=["model_type", "window"], how="left").merge(
        paper_median_error(), on=["model_type", "window"], how="left"
    )
    return pd.DataFrame(
        {
            "model": table.model_type.map(model_label),
            "window": table.window,
            "rollouts": table.rollouts,
            "blow-ups": table.apply(lambda r: with_interval(r.blowups, r.blowups_low, r.blowups_high, ".0f"), axis=1),
            "paper blow-ups": table.paper_blowups,
            "median AN-RFMSE": table.apply(lambda r: with_interval(r["median"], r.median_low, r.median_high), axis=1),
            "paper median": table.paper_median,
        }
    )
