"""The benchmark's numbers: each drawn case judged, and the rates per sensor set with their intervals.

Per sensor set: **precision** = names right / names given (a null named counts as a wrong name);
**recall** = names right / cases with an effect; both with a Wilson 95 % interval.  Cases found
"not identifiable" are counted apart (with the truth among the listed equivalents or not), as are
false alarms (a null flagged but not named) and false names (a null named).
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.stats import binomtest

from ..discover.cases.drawn import DRAWN_NAME, draw_effect
from ..discover.rates import STRONG_SIGNAL
from ..discover.summary import judged

__all__ = [
    "case_table", "peer_rates", "peers_markdown", "projected_hours", "rates", "rates_markdown", "recall_by_signal",
    "strong_by_kind", "strong_by_kind_markdown", "wilson",
]  # fmt: skip


def wilson(successes: int, trials: int, level: float = 0.95) -> tuple[float, float]:
    """The Wilson score interval of a proportion (nan, nan when there are no trials)."""
    if trials == 0:
        return float("nan"), float("nan")
    interval = binomtest(int(successes), int(trials)).proportion_ci(level, method="wilson")
    return float(interval.low), float(interval.high)


def case_table(
    findings_paths: Sequence[str | Path],
    signal_paths: Sequence[str | Path],
    sensors: Sequence[str],
    seconds: Sequence[float],
) -> pd.DataFrame:
    """One row per case and sensor set (the sequences in the same order): the truth, the answer, the verdict."""
    rows = []
    for path, signal_path, sensor_set, spent in zip(findings_paths, signal_paths, sensors, seconds, strict=True):
        f = json.loads(Path(path).read_text())
        case = f["case"].split("/")[0]
        effect = draw_effect(int(DRAWN_NAME.fullmatch(case).group(1)))
        shown = json.loads(Path(signal_path).read_text())
        rows.append({
            "case": case, "sensors": sensor_set, "seed": effect.seed, "kind": effect.kind, "truth": effect.key or "",
            "family": effect.family, "in_library": effect.in_library, "size": effect.size, "noise": effect.noise,
            "signal": shown["signal"], "samples": shown["samples"], "accepted": " ".join(f["accepted"]),
            "changes": " ".join(f["expected_equations"]),
            "flagged": " ".join(f.get("flagged_equations", f.get("flagged_channels", []))),
            "outcome": f["outcome"], "named": " then ".join(f["named"]), "verdict": judged(f), "seconds": spent,
        })  # fmt: skip
    return pd.DataFrame(rows)


def rates(table: pd.DataFrame, order: Sequence[str] | None = None) -> pd.DataFrame:
    """Per sensor set: the counts, precision, recall and the recall on strong effects (signal >= :data:`STRONG_SIGNAL`)
    with their Wilson 95 % intervals, and seconds a case."""
    rows = []
    for sensor_set, group in table.groupby("sensors", sort=False):
        count = group.verdict.value_counts()
        effects, nulls = int((group.kind != "none").sum()), int((group.kind == "none").sum())
        right, names = int(count.get("right", 0)), int(count.reindex(["right", "wrong", "false name"]).fillna(0).sum())
        row: dict = {"sensors": sensor_set, "cases": len(group), "effects": effects, "nulls": nulls}
        row |= {verdict: int(count.get(verdict, 0)) for verdict in _COUNTED}
        strong = _strong_effects(group)
        row |= _rate("precision", right, names) | _rate("recall", right, effects)
        strong_right = int((strong.verdict == "right").sum())
        row |= {"strong_effects": len(strong), "strong_right": strong_right}
        row |= _rate("strong_recall", strong_right, len(strong))
        row |= _rate("false_alarm_rate", int(count.get("false alarm", 0) + count.get("false name", 0)), nulls)
        row |= {"median_seconds": float(group.seconds.median()), "total_seconds": float(group.seconds.sum())}
        rows.append(row)
    result = pd.DataFrame(rows)
    return result.set_index("sensors").loc[list(order)].reset_index() if order else result


def _strong_effects(table: pd.DataFrame) -> pd.DataFrame:
    """The cases with an effect whose signal is at least :data:`STRONG_SIGNAL`."""
    return table[(table.kind != "none") & (table.signal >= STRONG_SIGNAL)]


_COUNTED = (
    "right", "wrong", "not identifiable, truth listed", "not identifiable, truth not listed", "unexplained", "missed",
    "quiet", "false alarm", "false name",
)  # fmt: skip


def _rate(name: str, successes: int, trials: int) -> dict[str, float]:
    low, high = wilson(successes, trials)
    return {name: successes / trials if trials else float("nan"), f"{name}_low": low, f"{name}_high": high}


def recall_by_signal(table: pd.DataFrame, edges: Sequence[float]) -> pd.DataFrame:
    """Per sensor set and signal bin [edge_i, edge_i+1): the effects, the names right, the recall and its interval."""
    effects = table[table.kind != "none"]
    rows = []
    for sensor_set, group in effects.groupby("sensors", sort=False):
        bins = pd.cut(group.signal.replace(np.inf, np.finfo(float).max), list(edges), right=False)
        for interval, members in group.groupby(bins, observed=False):
            right = int((members.verdict == "right").sum())
            rows.append({"sensors": sensor_set, "signal_from": interval.left, "signal_to": interval.right,
                         "effects": len(members), "right": right, **_rate("recall", right, len(members))})  # fmt: skip
    return pd.DataFrame(rows)


#: how an effect the record shows strongly was not named, in the words of the page: (verdicts, what it means)
MISSES = {
    "wrong": (("wrong",), "another hypothesis named"),
    "not identifiable": (("not identifiable, truth listed", "not identifiable, truth not listed"),
                         "other physics fitted alike"),
    "unexplained": (("unexplained",), "flagged, no fitted form explained enough"),
    "missed": (("missed",), "no channel beyond its noise"),
}  # fmt: skip


def strong_by_kind(table: pd.DataFrame) -> pd.DataFrame:
    """Per sensor set and kind of hidden effect, the effects whose signal is at least :data:`STRONG_SIGNAL`:
    how many, named right (the recall with its interval), and how each of the others ended (:data:`MISSES`)."""
    strong = _strong_effects(table)
    rows = []
    for (sensor_set, kind), group in strong.groupby(["sensors", "kind"], sort=False):
        right = int((group.verdict == "right").sum())
        row = {"sensors": sensor_set, "kind": kind, "effects": len(group), "right": right}
        row |= {miss: int(group.verdict.isin(verdicts).sum()) for miss, (verdicts, _) in MISSES.items()}
        rows.append(row | _rate("recall", right, len(group)))
    columns = ["sensors", "kind", "effects", "right", *MISSES, "recall", "recall_low", "recall_high"]
    return pd.DataFrame(rows, columns=columns)


def strong_by_kind_markdown(table: pd.DataFrame) -> str:
    """:func:`strong_by_kind` as a Markdown table, with what each way of missing means."""
    meanings = "; ".join(f"{miss}: {meaning}" for miss, (_, meaning) in MISSES.items())
    lines = [
        f"Effects of signal >= {STRONG_SIGNAL:.0f} noise units, by kind: which are named and how the others "
        f"ended ({meanings}).",
        "",
        "| sensors | kind | effects | right | " + " | ".join(MISSES) + " | recall |",
        "|---|---|---|---|" + "---|" * len(MISSES) + "---|",
    ]
    for row in table.to_dict(orient="records"):
        misses = " | ".join(str(row[miss]) for miss in MISSES)
        lines.append(f"| {row['sensors']} | {row['kind']} | {row['effects']} | {row['right']} | {misses} "
                     f"| {_percent(row, 'recall')} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def rates_markdown(rates_table: pd.DataFrame, split: str, size: str) -> str:
    """The rates as a Markdown table (the page the workflow writes, and the guide's first table)."""
    lines = [
        f"Drawn cases of the `{split}` seeds, size `{size}`: precision = names right / names given, recall = names "
        "right / cases with an effect (Wilson 95 % intervals); not identifiable: the truth among the equivalents "
        "listed / not; s a case: the median of its jobs' seconds.",
        "",
        "| sensors | cases (nulls) | precision | recall | right / wrong | not identifiable (truth listed / not) "
        "| unexplained / missed | nulls flagged / named | s a case |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rates_table.to_dict(orient="records"):
        lines.append(
            f"| {row['sensors']} | {row['cases']} ({row['nulls']}) | {_percent(row, 'precision')} "
            f"| {_percent(row, 'recall')} | {row['right']} / {row['wrong']} | {row['not identifiable, truth listed']} / "
            f"{row['not identifiable, truth not listed']} | {row['unexplained']} / {row['missed']} "
            f"| {row['false alarm']} / {row['false name']} | {row['median_seconds']:.0f} |"
        )
    return "\n".join(lines) + "\n"


def projected_hours(rates_table: pd.DataFrame, sizes: Mapping[str, Mapping[str, int]], cores: Sequence[int]) -> str:
    """What each configured size would take, from this run's mean job seconds a case per sensor set (the
    jobs of different cases are independent, so N cores divide the job time until the last case's chain)."""
    mean = (rates_table.set_index("sensors").total_seconds / rates_table.set_index("sensors").cases).to_dict()
    lines = ["| size | cases | job hours | " + " | ".join(f"on {n} cores" for n in cores) + " |",
             "|---|---|---|" + "---|" * len(cores)]  # fmt: skip
    for size, counts in sizes.items():
        if not set(counts) <= set(mean):
            continue
        hours = sum(count * mean[sensor_set] for sensor_set, count in counts.items()) / 3600
        longest = max(mean[sensor_set] for sensor_set in counts) / 3600
        walls = " | ".join(_duration(max(hours / n, longest)) for n in cores)
        lines.append(f"| {size} | {sum(counts.values())} | {hours:.1f} | {walls} |")
    return "\n".join(lines) + "\n"


def _duration(hours: float) -> str:
    return f"{hours:.1f} h" if hours >= 1 else f"{hours * 60:.0f} min"


def peer_rates(rows: pd.DataFrame) -> pd.DataFrame:
    """Per method on the full set's drawn cases (the peers' rows, :mod:`costa.peers`): the share of cases with an
    effect where the equation it changes most is one the effect changes, with its interval; its spurious terms
    (in an equation the effect leaves alone) a case; and the nulls in which it changed any equation."""
    result = []
    for method, group in rows.groupby("method", sort=False):
        effects, nulls = group[group.true_equations != "none"], group[group.true_equations == "none"]
        right = sum(m in t.split() for m, t in zip(effects.most_changed, effects.true_equations, strict=True))
        result.append({
            "method": method, "effects": len(effects), **_rate("most_changed_right", right, len(effects)),
            "spurious_terms_a_case": float(group.spurious_terms.mean()),
            "nulls": len(nulls), "nulls_changed": int((nulls.equations_changed != "none").sum()),
            "median_seconds": float(group.seconds.median()),
        })  # fmt: skip
    return pd.DataFrame(result)


def peers_markdown(table: pd.DataFrame) -> str:
    """The peers' rates as a Markdown table."""
    lines = [
        "| method | the equation it changes most is the effect's | spurious terms a case | nulls changed "
        "| s a case (median) |",
        "|---|---|---|---|---|",
    ]
    for row in table.to_dict(orient="records"):
        lines.append(
            f"| {row['method']} | {_percent(row, 'most_changed_right')} ({row['effects']} effects) "
            f"| {row['spurious_terms_a_case']:.1f} | {row['nulls_changed']} of {row['nulls']} "
            f"| {row['median_seconds']:.0f} |"
        )
    return "\n".join(lines) + "\n"


def _percent(row: Mapping, name: str) -> str:
    if not np.isfinite(row[name]):
        return "—"
    return f"{row[name]:.0%} [{row[f'{name}_low']:.0%}, {row[f'{name}_high']:.0%}]"
