"""How often a name is right: the discovery benchmark's rates on its test seeds, as published with the
package (``benchmark_rates.csv``, a copy of a test run's ``results/benchmark/rates.csv``), in words
for a findings page; and how often the truth was among the explanations a recommended measurement
separates (``truth_listed.csv``, a copy of a dev run's ``results/benchmark/truth_listed.csv``: dev, so
that the closed loop on the test seeds judges the chances it calibrates)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

__all__ = ["LISTED", "PUBLISHED", "STRONG_SIGNAL", "how_often_right", "truth_listed", "undecided_outcome"]

PUBLISHED = Path(__file__).with_name("benchmark_rates.csv")
LISTED = Path(__file__).with_name("truth_listed.csv")
#: an effect whose signal (noise units, root-sum-square over the record's samples) is at least this is
#: strong: its recall is the one a findings page quotes
STRONG_SIGNAL = 100.0


def _share(right: int, trials: int, low: float, high: float) -> str:
    return f"{right} of {trials} ({right / trials:.0%}, 95 % interval {low:.0%}-{high:.0%})" if trials else "none of 0"


def how_often_right(records: str, path: Path = PUBLISHED) -> list[str]:
    """How often the benchmark's test seeds saw a name right and a strong effect named on its sensor set
    ``records``, the one whose records are sampled as the data are (:attr:`.route.Route.records`); nothing
    where no test run of it is published."""
    if not path.exists():
        return []
    table = pd.read_csv(path).set_index("sensors")
    if records not in table.index or table.loc[records, "split"] != "test":
        return []
    r = table.loc[records]
    names = int(r["right"] + r["wrong"] + r["false name"])
    named = (
        f"a name was right in {_share(int(r['right']), names, r['precision_low'], r['precision_high'])}"
        if names
        else "no name was given"
    )
    strong = _share(int(r["strong_right"]), int(r["strong_effects"]), r["strong_recall_low"], r["strong_recall_high"])
    return [
        f"on the benchmark's {records} records ({int(r['cases'])} drawn cases of its test seeds, {r['size']} size), "
        f"{named}; effects above {STRONG_SIGNAL:g} noise units were named right in {strong}"
    ]


def undecided_outcome(verdict: str) -> str:
    """The outcome of a round that recommends a measurement, from its ``verdict``: unexplained or not identifiable
    (the rows of ``truth_listed.csv``)."""
    return "unexplained" if verdict.startswith("unexplained") else "not identifiable"


def truth_listed(records: str, outcome: str, path: Path = LISTED) -> dict[str, float | int | str] | None:
    """How often, on the benchmark's ``records`` of its dev seeds, a round of ``outcome`` (unexplained, not
    identifiable) that recommended a measurement held the truth among the explanations it compared: rounds,
    listed, share, share_low, share_high, split, size; None where no such round was counted."""
    if not path.exists():
        return None
    table = pd.read_csv(path)
    row = table[(table.sensors == records) & (table.outcome == outcome)]
    return None if row.empty else row.astype(object).iloc[0].to_dict()  # plain numbers, for JSON
