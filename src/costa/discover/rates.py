"""How often a name is right: the discovery benchmark's rates on its test seeds, as published with the
package (``benchmark_rates.csv``, a copy of a test run's ``results/benchmark/rates.csv``), in words
for a findings page."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

__all__ = ["PUBLISHED", "ROUTE_SETS", "STRONG_SIGNAL", "how_often_right"]

PUBLISHED = Path(__file__).with_name("benchmark_rates.csv")
#: the benchmark's sensor sets whose records a route decides: every state; channels by the filter;
#: hand samples by multiple shooting (a plant's and a pot line's)
ROUTE_SETS = {"full": ("full",), "filter": ("partial",), "shooting": ("plant", "pot_line")}
#: an effect whose signal (noise units, root-sum-square over the record's samples) is at least this is
#: strong: its recall is the one a findings page quotes
STRONG_SIGNAL = 100.0


def _share(right: int, trials: int, low: float, high: float) -> str:
    return f"{right} of {trials} ({right / trials:.0%}, 95 % interval {low:.0%}-{high:.0%})" if trials else "none of 0"


def how_often_right(route: str, path: Path = PUBLISHED) -> list[str]:
    """For each sensor set of ``route`` (:data:`ROUTE_SETS`), how often the benchmark's test seeds saw a
    name right and a strong effect named; nothing where no test run is published."""
    if not path.exists():
        return []
    table = pd.read_csv(path).set_index("sensors")
    sentences = []
    for sensors in ROUTE_SETS[route]:
        if sensors not in table.index or table.loc[sensors, "split"] != "test":
            continue
        r = table.loc[sensors]
        names = int(r["right"] + r["wrong"] + r["false name"])
        named = (
            f"a name was right in {_share(int(r['right']), names, r['precision_low'], r['precision_high'])}"
            if names
            else "no name was given"
        )
        strong = _share(
            int(r["strong_right"]), int(r["strong_effects"]), r["strong_recall_low"], r["strong_recall_high"]
        )
        sentences.append(
            f"on the benchmark's {sensors} records ({int(r['cases'])} drawn cases of its test seeds, {r['size']} size), "
            f"{named}; effects above {STRONG_SIGNAL:g} noise units were named right in {strong}"
        )
    return sentences
