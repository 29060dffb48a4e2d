"""Does "what to measure next" deliver what it predicts?  The closed loop, judged.

A case whose findings end without a name gets its first round's top recommendation added to its
record (:func:`top_recommendation`) and is discovered again.  Each recommendation predicted two
numbers (:mod:`costa.discover.sparse.measure_next`): the separation of the best explanation from its
nearest rival, in noise stds, and the chance the added record names one; and, where the benchmark published
how often the truth is among the explanations (:mod:`.truth_listed`), the chance of a right name.
:func:`loop_row` sets them beside what the run with the added channel achieved: the separation, read from how far the two
explanations' BIC gains moved apart (sqrt(|change of their BIC difference|), whose mean is the
predicted d^2 where the prediction holds), and whether a name came and was right.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from ..discover.summary import judged
from .score import wilson

__all__ = ["achieved_separation", "loop_markdown", "loop_row", "loop_summary", "loop_table", "top_recommendation"]


def top_recommendation(found: Mapping[str, Any]) -> dict[str, Any] | None:
    """The first round's top recommendation of an instrument where the run ended without a name (None: it named,
    recommended nothing, or more of the same record, which the loop does not simulate); what the record measures
    as often is never recommended (:func:`..discover.sparse.measure_next`)."""
    recommended = found["rounds"][0].get("measure_next", [])
    return recommended[0] if recommended and recommended[0]["channel"] and not found["named"] else None


def _gains(found: Mapping[str, Any]) -> dict[str, float]:
    """Every first-round candidate's BIC gain by hypothesis key (the ones it reports)."""
    first = found["rounds"][0]
    listed = [first.get("correction") or {}, *first.get("equivalent", []), *first.get("alternatives", [])]
    return {c["hypothesis"]: c["bic_gain"] for c in listed if c and c.get("bic_gain") is not None}


def achieved_separation(before: Mapping[str, Any], after: Mapping[str, Any], best: str, rival: str) -> float:
    """sqrt(|change of the BIC difference of ``best`` and ``rival``|) from ``before`` to ``after`` (the
    added channel's share of it), in noise stds; nan where either run does not report both."""
    was, now = _gains(before), _gains(after)
    if not {best, rival} <= was.keys() & now.keys():
        return float("nan")
    return float(np.sqrt(abs((now[best] - now[rival]) - (was[best] - was[rival]))))


def loop_row(
    case: str, sensors: str, before: Mapping[str, Any], added: Mapping[str, Any] | None, after: Mapping[str, Any] | None
) -> dict[str, Any]:
    """One case of the loop: its verdict before, the channel added (None: nothing recommended), what was
    predicted and what was achieved, the verdict after."""
    row: dict[str, Any] = {"case": case, "sensors": sensors, "before": judged(before), "added": None}
    if added is None or after is None:
        return row
    best = added.get("best") or (before["rounds"][0].get("correction") or {}).get("hypothesis")
    return row | {
        "added": added["channel"], "every_s": added["every_s"], "rival": added.get("rival"),
        "predicted_separation": added["separation_noise_stds"], "predicted_name": added.get("name_probability"),
        "predicted_right_name": added.get("right_name_probability"),
        "achieved_separation": achieved_separation(before, after, best, added["rival"]) if best and added.get("rival")
        else float("nan"),
        "after": judged(after), "named_after": " then ".join(after["named"]),
    }  # fmt: skip


#: the verdicts of a run that found an effect and named nothing (what a measurement should decide)
UNDECIDED = ("unexplained", "not identifiable, truth listed", "not identifiable, truth not listed")


def loop_summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per sensor set: the cases undecided (:data:`UNDECIDED`), those given a measurement, the names predicted
    (the sum of the chances) and given, the right names predicted (nan where a chance is missing) and gained with
    their Wilson interval, wrong names, and the median predicted and achieved separations."""
    rows = []
    for sensors, group in table.groupby("sensors", sort=False):
        group = group[group.before.isin(UNDECIDED)]
        looped = group[group.added.notna()]
        named = looped[looped["after"].isin(["right", "wrong"])] if len(looped) else looped
        right = int((looped.get("after") == "right").sum()) if len(looped) else 0
        low, high = wilson(right, len(looped))
        rows.append({
            "sensors": sensors, "undecided": len(group), "measurement_added": len(looped),
            "names_predicted": float(looped.predicted_name.sum()) if len(looped) else 0.0, "names_given": len(named),
            "right_predicted": float(looped.predicted_right_name.sum(min_count=len(looped))) if len(looped) else 0.0,
            "right_gained": right, "right_rate_low": low, "right_rate_high": high,
            "wrong_gained": len(named) - right,
            "median_predicted_separation": float(looped.predicted_separation.median()) if len(looped) else np.nan,
            "median_achieved_separation": float(looped.achieved_separation.median()) if len(looped) else np.nan,
        })  # fmt: skip
    return pd.DataFrame(rows)


def loop_markdown(summary: pd.DataFrame, table: pd.DataFrame, split: str) -> str:
    """The loop's page: the summary per sensor set, then every case."""
    lines = [
        f"The closed loop on the `{split}` seeds: each case that found an effect and named nothing (unexplained or "
        "not identifiable), its first round's top "
        "recommendation added to its record and discovered again. Names predicted: the sum of each "
        "recommendation's chance of a name (right names: of a right name, that chance times the share of the "
        "benchmark's dev rounds whose explanations held the truth; nan where none were published); separations "
        "in noise stds, the best explanation from its nearest rival (achieved: from how far their BIC gains moved "
        "apart).",
        "",
        "| sensors | undecided | measurement added | names predicted / given | right names predicted / gained (95 %) "
        "| wrong gained | separation predicted / achieved (medians) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in summary.to_dict(orient="records"):
        rate = (
            f"{r['right_gained']} [{100 * r['right_rate_low']:.0f}, {100 * r['right_rate_high']:.0f} %]"
            if r["measurement_added"] else "—"
        )  # fmt: skip
        lines.append(
            f"| {r['sensors']} | {r['undecided']} | {r['measurement_added']} | {r['names_predicted']:.1f} / "
            f"{r['names_given']} | {r['right_predicted']:.1f} / {rate} | {r['wrong_gained']} | {r['median_predicted_separation']:.1f} / "
            f"{r['median_achieved_separation']:.1f} |"
        )
    lines += [
        "",
        "| case | sensors | before | added | predicted (separation, name) | achieved | after |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in table.to_dict(orient="records"):
        if r.get("added") is None or (isinstance(r.get("added"), float) and np.isnan(r["added"])):
            lines.append(f"| {r['case']} | {r['sensors']} | {r['before']} | nothing recommended | | | |")
            continue
        lines.append(
            f"| {r['case']} | {r['sensors']} | {r['before']} | {r['added']} every {r['every_s']:g} s "
            f"| {r['predicted_separation']:.1f}, {r['predicted_name']:.2f} | {r['achieved_separation']:.1f} "
            f"| {r['after']} {r['named_after'] or ''} |"
        )
    return "\n".join(lines) + "\n"


def loop_table(rows: Sequence[Mapping[str, Any]]) -> pd.DataFrame:
    """The loop's rows as a table (every column present, nothing recommended as NaN)."""
    columns = ["case", "sensors", "before", "added", "every_s", "rival", "predicted_separation", "predicted_name",
               "predicted_right_name", "achieved_separation", "after", "named_after"]  # fmt: skip
    return pd.DataFrame(list(rows)).reindex(columns=columns)
