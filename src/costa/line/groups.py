"""The line's table, the pots that disagree alike grouped, and a group's pots pooled into one data set.

A group is the pots with the same signature (:func:`.screen.signature`): the same channels flagged,
each with the same sign of its innovations' bias.  Pots that deviate the same way are likely to
miss the same physics, and together they hold more evidence than one: a daily sample a pot is
little, twenty pots' are a lot.  A group's pots become the trajectories of one data set
(:func:`pooled_record`), on which discovery runs as on several cells: one name, one closed form.
"""

from __future__ import annotations

import string
from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

__all__ = ["group_meta", "group_pots", "line_page", "line_table", "pooled_record"]


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


def group_pots(screens: Mapping[str, Mapping[str, Any]]) -> list[dict[str, Any]]:
    """The pots that disagree alike, one group a signature, the largest first (then by their first pot),
    named A, B, ...: [{group, signature, pots}].  Pots that agree with the model belong to none."""
    by_signature: dict[str, list[str]] = {}
    for pot, screen in screens.items():
        if screen["signature"]:
            by_signature.setdefault(screen["signature"], []).append(pot)
    ordered = sorted(by_signature.items(), key=lambda item: (-len(item[1]), item[1][0]))
    return [
        {"group": _label(i), "signature": sig, "pots": pots} for i, (sig, pots) in enumerate(ordered)
    ]  # fmt: skip


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
    meta: dict[str, Any] = {"data": f"pots {', '.join(pots)} of the line {line.name} ({group['signature']})"}
    if not line.simulated:
        return meta
    effects = sorted({line.effects[pot] for pot in pots})
    meta["hidden"] = "; ".join(f"{CASES[e].hidden} ({sum(line.effects[p] == e for p in pots)} pots)" for e in effects)
    meta["kind"] = "a line's group of pots"
    if len(effects) == 1:
        case = CASES[effects[0]]
        meta |= {"expected_equations": list(case.expected_equations), "accepted": list(case.accepted)}
    return meta


def line_page(line, table: pd.DataFrame, groups: Sequence[Mapping[str, Any]], findings: Mapping[str, Mapping]) -> str:
    """The line's page: its pots by how they disagree, each group's outcome, and on a simulated line how
    the groups match what is hidden (``findings``: group -> its findings.json)."""
    pots = table.groupby("pot", sort=False).first()
    group_of = {pot: g["group"] for g in groups for pot in g["pots"]}
    flagged = sum(bool(s) for s in pots["signature"])
    lines = [
        f"# The line {line.name}", "",
        f"{len(pots)} pots screened with the starting model ({line.starting_model}); {flagged} disagree beyond noise, "
        f"in {len(groups)} group{'s' * (len(groups) != 1)} of the same channels and signs.", "",
        "| pot | group | disagrees (channel, sign of the bias) | largest chi2/dof" + (" | hidden |" if line.simulated else " |"),
        "|---|---|---|---|" + ("---|" if line.simulated else ""),
    ]  # fmt: skip
    largest = table.groupby("pot", sort=False)["chi2_per_dof"].max()
    for pot, row in pots.iterrows():
        cells = [pot, group_of.get(pot, "—"), row["signature"] or "nothing", f"{largest[pot]:.3g}"]
        lines.append("| " + " | ".join(cells + ([row["hidden"]] if line.simulated else [])) + " |")
    lines += ["", "| group | pots | outcome | named | closed form |", "|---|---|---|---|---|"]
    for g in groups:
        f = findings.get(g["group"], {})
        correction = next((r.get("correction") for r in f.get("rounds", []) if r.get("correction")), None)
        lines.append(
            f"| {g['group']} | {', '.join(g['pots'])} | {f.get('outcome', '—')} | {', '.join(f.get('named', [])) or '—'} "
            f"| {correction['closed_form'] if correction else '—'} |"
        )
    if line.simulated:
        lines += ["", *_scored(line, pots, groups, findings)]
    return "\n".join(lines) + "\n"


def _scored(
    line, pots: pd.DataFrame, groups: Sequence[Mapping[str, Any]], findings: Mapping[str, Mapping]
) -> list[str]:
    """How a simulated line's groups match what its pots hide."""
    from ..discover.summary import judged

    quiet = [pot for pot in pots.index if line.effects[pot] == "no_effect"]
    false = [pot for pot in quiet if pots.loc[pot, "signature"]]
    words = [f"Pots hiding nothing: {len(quiet)}, flagged {len(false)}" + (f" ({', '.join(false)})." if false else ".")]
    for effect in sorted({e for e in line.effects.values() if e != "no_effect"}):
        hiding = [pot for pot in pots.index if line.effects[pot] == effect]
        found = [g["group"] for g in groups if set(g["pots"]) & set(hiding)]
        verdicts = [f"{g}: {judged(findings[g])}" for g in found if g in findings and "accepted" in findings[g]]
        words.append(
            f"{effect} ({', '.join(hiding)}): in group{'s' * (len(found) != 1)} {', '.join(found) or 'none'}"
            + (f"; {'; '.join(verdicts)}" if verdicts else "") + "."
        )  # fmt: skip
    return words
