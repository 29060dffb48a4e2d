"""The line's table, the pots that disagree alike grouped, and a group's pots pooled into one data set.

A group is pots that disagree and that one hypothesis explains as well as any (:func:`group_pots`,
from the first round's screen on each pot, :func:`.screen.screen_pot`): pots that deviate the same
way are likely to miss the same physics, and together they hold more evidence than one: a daily
sample a pot is little, twenty pots' are a lot.  (The channels' signs do not group them: under a
pot line's controllers one feeder fault biased the bath temperature up in one pot and down in
another.)  A group's pots become the trajectories of one data set (:func:`pooled_record`), on which
discovery runs as on several cells: one name, one closed form.
"""

from __future__ import annotations

import string
from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

__all__ = ["group_meta", "group_pots", "line_table", "pooled_record"]


def line_table(screens: Mapping[str, Mapping[str, Any]], effects: Mapping[str, str] | None = None) -> pd.DataFrame:
    """One row per pot and channel: the screen's tests (:func:`.screen.screen_pot`), the pot's signature
    and, for a simulated line, the effect hidden in it (``effects``: pot -> case)."""
    rows = [
        {"pot": pot, "channel": c["channel"], **{k: v for k, v in c.items() if k != "channel"},
         "signature": screen["signature"], "hidden": (effects or {}).get(pot, "")}
        for pot, screen in screens.items()
        for c in screen["channels"]
    ]  # fmt: skip
    return pd.DataFrame(rows)


def group_pots(screens: Mapping[str, Mapping[str, Any]], equivalence: float) -> list[dict[str, Any]]:
    """The pots that disagree alike, the largest group first (then by its first pot), named A, B, ...:
    [{group, hypothesis, pots, signatures}].  A hypothesis explains a pot when its screened gain is
    within ``equivalence`` of BIC of the pot's best (:attr:`...DiscoverySettings.equivalence`: the
    pot's data cannot tell them apart); the hypothesis that explains the most pots (then the largest
    summed gain) takes them as one group, and so on with the pots left.  Pots that agree with the
    model belong to none; a pot that disagrees but that no hypothesis explains is a group of its own
    (hypothesis None)."""
    left = {pot: _explaining(screen["best"], equivalence) for pot, screen in screens.items() if screen["flagged"]}
    found: list[tuple[str | None, list[str]]] = []
    while any(left.values()):
        support: dict[str, list[float]] = {}
        for explaining in left.values():
            for hypothesis, gain in explaining.items():
                support.setdefault(hypothesis, []).append(gain)
        best = max(sorted(support), key=lambda h: (len(support[h]), sum(support[h])))
        found.append((best, [pot for pot, explaining in left.items() if best in explaining]))
        left = {pot: explaining for pot, explaining in left.items() if best not in explaining}
    found += [(None, [pot]) for pot in left]
    ordered = sorted(found, key=lambda item: (-len(item[1]), item[1][0]))
    return [
        {"group": _label(i), "hypothesis": hypothesis, "pots": pots,
         "signatures": {pot: screens[pot]["signature"] for pot in pots}}
        for i, (hypothesis, pots) in enumerate(ordered)
    ]  # fmt: skip


def _explaining(best: Sequence[Mapping[str, Any]], equivalence: float) -> dict[str, float]:
    """hypothesis -> screened gain, of the hypotheses within ``equivalence`` of BIC (twice the
    log-likelihood) of the best of ``best`` (the pot's screen, best first)."""
    return {b["hypothesis"]: b["gain"] for b in best if 2 * (best[0]["gain"] - b["gain"]) <= equivalence}


def _label(index: int) -> str:
    """A, B, ..., Z, AA, AB, ..."""
    letters = string.ascii_uppercase
    return letters[index] if index < len(letters) else _label(index // len(letters) - 1) + letters[index % len(letters)]


def pooled_record(records: Sequence[pd.DataFrame]) -> pd.DataFrame:
    """A group's pots' records (one trajectory each) as one data set, pot i the trajectory i, each cut to
    the first samples of the shortest (discovery stacks trajectories of one length)."""
    shortest = min(len(record) for record in records)
    pooled = []
    for i, record in enumerate(records):
        ids = record["trajectory"].unique()
        if len(ids) != 1:
            raise ValueError(f"a pot's record holds one trajectory, this one {len(ids)}")
        pooled.append(record.iloc[:shortest].assign(trajectory=i))
    return pd.concat(pooled, ignore_index=True)


def group_meta(line, group: Mapping[str, Any]) -> dict[str, Any]:
    """What a group's findings record of its data and, on a simulated line, of what its pots hide: the
    shipped case's truth where every pot of the group hides the same effect (else none to judge by)."""
    from ..discover.cases.shipped import CASES

    pots = group["pots"]
    explained = f"explained by {group['hypothesis']}" if group["hypothesis"] else "explained by none"
    if group.get("again"):
        explained = (
            f"groups {', '.join(group['from'])} pooled again by what group {group['group']}'s correction explained"
        )
    else:
        explained += " one by one"
    meta: dict[str, Any] = {"data": f"pots {', '.join(pots)} of the line {line.name} ({explained})"}
    if not line.simulated:
        return meta
    effects = sorted({line.effects[pot] for pot in pots})
    meta["hidden"] = "; ".join(f"{CASES[e].hidden} ({sum(line.effects[p] == e for p in pots)} pots)" for e in effects)
    meta["kind"] = "a line's group of pots"
    if len(effects) == 1:
        case = CASES[effects[0]]
        meta |= {"expected_equations": list(case.expected_equations), "accepted": list(case.accepted)}
    return meta
