"""The line's page: its pots by how they disagree, each group's outcome and its correction checked on
the pots, and on a simulated line how the groups match what is hidden."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

from .check import differing_pots, explained_pots

__all__ = ["line_page"]


def line_page(
    line, table: pd.DataFrame, groups: Sequence[Mapping[str, Any]], findings: Mapping[str, Mapping],
    checks: Mapping[str, pd.DataFrame], pooled: Sequence[Mapping[str, Any]] = (),
    pooled_findings: Mapping[str, Mapping] | None = None, pooled_checks: Mapping[str, pd.DataFrame] | None = None,
) -> str:  # fmt: skip
    """The page of ``line`` from its table (:func:`.groups.line_table`), its ``groups``, each group's
    ``findings`` (group -> its findings.json) and ``checks`` (group -> its correction on every pot that
    disagrees, :func:`.check.check_pots`); ``pooled``: the second pass's groups (:func:`.pooled.pool_again`),
    with the findings and checks of those searched again.  The line's answer is the second pass's."""
    pooled_findings, pooled_checks = pooled_findings or {}, pooled_checks or {}
    pots = table.groupby("pot", sort=False).first()
    group_of = {pot: g["group"] for g in groups for pot in g["pots"]}
    flagged = sum(bool(s) for s in pots["signature"])
    lines = [
        f"# The line {line.name}", "",
        f"{len(pots)} pots screened with the starting model ({line.starting_model}); {flagged} disagree beyond noise, "
        f"in {len(groups)} group{'s' * (len(groups) != 1)}, each of the pots that one hypothesis explains as well as any.", "",
        "| pot | group | disagrees (channel, sign of the bias) | largest chi2/dof | explained by"
        + (" | hidden |" if line.simulated else " |"),
        "|---|---|---|---|---|" + ("---|" if line.simulated else ""),
    ]  # fmt: skip
    largest = table.groupby("pot", sort=False)["chi2_per_dof"].max()
    best = {pot: h for g in groups for pot in g["pots"] if (h := g["hypothesis"])}
    for pot, row in pots.iterrows():
        cells = [pot, group_of.get(pot, "—"), row["signature"] or "nothing", f"{largest[pot]:.3g}", best.get(pot, "—")]
        lines.append("| " + " | ".join(cells + ([row["hidden"]] if line.simulated else [])) + " |")
    lines += ["", *_group_table(groups, findings, checks)]
    lines += [
        "", "Each group's correction is checked on every pot that disagrees, alone. A pot of the group it leaves "
        "disagreeing differs from the rest: the effect stronger or weaker in it (its coefficient), or something more "
        "missing. A pot of another group it brings within noise misses the same physics (the one-by-one screens could "
        "not tell).",
    ]  # fmt: skip
    again = [g for g in pooled if g["again"]]
    if again:
        lines += [
            "", "Pooled again: a pot its own group's correction leaves disagreeing moves to the first group whose "
            "correction brings it within noise, two groups whose corrections each bring the other's pots within noise "
            "are one, and each group whose pots changed is searched again on them together.",
            "", *_group_table(again, pooled_findings, pooled_checks, pooled=True),
        ]  # fmt: skip
        findings = {g["group"]: (pooled_findings if g["again"] else findings).get(g["group"], {}) for g in pooled}
        checks = {g["group"]: (pooled_checks if g["again"] else checks).get(g["group"]) for g in pooled}
        groups = pooled
    lines += ["", *_explanations(pots, groups, findings, checks)]
    if line.simulated:
        lines += ["", *_scored(line, pots, groups, findings, checks)]
    return "\n".join(lines) + "\n"


def _group_table(
    groups: Sequence[Mapping[str, Any]], findings: Mapping[str, Mapping], checks: Mapping[str, pd.DataFrame],
    pooled: bool = False,
) -> list[str]:  # fmt: skip
    """Each group's outcome, its correction and what the correction leaves and explains (``pooled``:
    with the first-pass groups its pots come from)."""
    source = ("| from groups ", "---|") if pooled else ("", "")
    lines = [
        f"| group | pots {source[0]}| outcome | named | closed form | its pots it leaves disagreeing | other pots it explains |",
        f"|---|---|{source[1]}---|---|---|---|---|",
    ]  # fmt: skip
    for g in groups:
        f, check = findings.get(g["group"], {}), checks.get(g["group"])
        correction = next((r.get("correction") for r in f.get("rounds", []) if r.get("correction")), None)
        left = differing_pots(check, pots=g["pots"]) if check is not None else []
        explains = explained_pots(check, g["pots"]) if check is not None else []
        origin = f"| {', '.join(g['from'])} " if pooled else ""
        lines.append(
            f"| {g['group']} | {', '.join(g['pots'])} {origin}| {f.get('outcome', '—')} | {', '.join(f.get('named', [])) or '—'} "
            f"| {correction['closed_form'] if correction else '—'} | {', '.join(left) or 'none'} | {', '.join(explains) or 'none'} |"
        )  # fmt: skip
    return lines


def _scored(
    line, pots: pd.DataFrame, groups: Sequence[Mapping[str, Any]], findings: Mapping[str, Mapping],
    checks: Mapping[str, pd.DataFrame],
) -> list[str]:  # fmt: skip
    """How a simulated line's groups match what its pots hide: for each effect the groups its pots are
    in, the pots each named group's correction explains (its own within noise and the others it
    brings there), and each group's verdict."""
    from ..discover.summary import judged

    quiet = [pot for pot in pots.index if line.effects[pot] == "no_effect"]
    false = [pot for pot in quiet if pots.loc[pot, "signature"]]
    words = [f"Pots hiding nothing: {len(quiet)}, flagged {len(false)}" + (f" ({', '.join(false)})." if false else ".")]
    for effect in sorted({e for e in line.effects.values() if e != "no_effect"}):
        hiding = [pot for pot in pots.index if line.effects[pot] == effect]
        found = [g for g in groups if set(g["pots"]) & set(hiding)]
        verdicts = [
            f"{g['group']}: {judged(findings[g['group']])}" for g in found
            if g["group"] in findings and "accepted" in findings[g["group"]]
        ]  # fmt: skip
        explained = [
            f"{g['group']}'s correction explains {', '.join(pots_) or 'none'}" for g in found
            if (pots_ := _explained_by(g, checks.get(g["group"])))
        ]  # fmt: skip
        words.append(
            f"{effect} ({', '.join(hiding)}): in group{'s' * (len(found) != 1)} {', '.join(g['group'] for g in found) or 'none'}"
            + "".join(f"; {w}" for w in verdicts + explained) + "."
        )  # fmt: skip
    return words


def _explanations(
    pots: pd.DataFrame, groups: Sequence[Mapping[str, Any]], findings: Mapping[str, Mapping],
    checks: Mapping[str, pd.DataFrame],
) -> list[str]:  # fmt: skip
    """The line's answer from the checks: each group's applied correction with the pots it brings within
    noise alone (its own and others'), and the flagged pots no group's correction explains."""
    words, explained = ["What explains the line's pots, each checked alone:"], set()
    for g in groups:
        f = findings.get(g["group"], {})
        applied = next((r for r in f.get("rounds", []) if r.get("correction")), None)
        if applied and (pots_ := _explained_by(g, checks.get(g["group"]))):
            explained.update(pots_)
            name = ", ".join(f.get("named", [])) or applied["correction"].get("hypothesis", "its correction")
            rivals = "".join(f", or {e['hypothesis']}" for e in applied.get("equivalent", []))
            words.append(f"- {name}{rivals} (group {g['group']}, {f['outcome']}): {', '.join(pots_)}")
    left = [pot for pot in pots.index if pots.loc[pot, "signature"] and pot not in explained]
    return words + [f"- no group's correction: {', '.join(left) or 'none'}"]


def _explained_by(group: Mapping[str, Any], check: pd.DataFrame | None) -> list[str]:
    """The pots a group's correction brings within noise: its own it does not leave disagreeing, and the others it explains."""
    if check is None:
        return []
    own = [pot for pot in group["pots"] if pot not in differing_pots(check, pots=group["pots"])]
    return own + explained_pots(check, group["pots"])
