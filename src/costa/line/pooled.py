"""The line's groups pooled again, from what each group's correction explains (a second pass).

The first pass groups the pots by their one-by-one screens, a few days each (:func:`.groups.group_pots`);
each group's correction is then checked on every pot that disagrees (:mod:`.check`).  A pot that its
own group's correction leaves disagreeing, and that another group's correction brings within noise
alone, misses that group's physics: it moves to that group (the first, in the groups' order, where
several do).  Two groups whose corrections each bring every pot of the other within noise explain
the same pots by two names: they are one group, the first of them, so that one name is decided on
all their pots (an AlF3-dependent conductivity on line24: three pots pooled named the bath's
conductivity, its fourth pot alone the cell voltage by 11 of BIC, each correction explaining the
other's pots).  A group whose pots changed is searched again on its pots together; the others keep
their first pass.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

from .check import differing_pots, explained_pots

__all__ = ["pool_again"]


def pool_again(groups: Sequence[Mapping[str, Any]], checks: Mapping[str, pd.DataFrame]) -> list[dict[str, Any]]:
    """The groups of the second pass, in the first pass's order: [{group, hypothesis, pots, signatures,
    from, again}], ``from`` the first-pass groups its pots were in, ``again`` whether its pots changed
    (it is searched again).  ``checks``: group -> its correction on every flagged pot
    (:func:`.check.check_pots`); a group without one explains nothing.  A group left with no pot is gone."""
    home = {pot: g["group"] for g in groups for pot in g["pots"]}
    pots_of = {g["group"]: list(g["pots"]) for g in groups}

    def explains_own(label: str, pot: str) -> bool:
        check = checks.get(label)
        return check is not None and pot not in differing_pots(check, pots=pots_of[label])

    moved: dict[str, str] = {}
    for g in groups:
        check = checks.get(g["group"])
        for pot in explained_pots(check, g["pots"]) if check is not None else []:
            if pot not in moved and not explains_own(home[pot], pot):
                moved[pot] = g["group"]
    into = _merged(groups, checks)
    pooled = []
    for g in groups:
        if into[g["group"]] != g["group"]:
            continue
        kept = [pot for f in groups if into[f["group"]] == g["group"] for pot in f["pots"] if pot not in moved]
        pots = kept + [pot for pot, to in moved.items() if into[to] == g["group"]]
        if not pots:
            continue
        signatures = {pot: s for f in groups for pot, s in f.get("signatures", {}).items() if pot in pots}
        pooled.append({
            "group": g["group"], "hypothesis": g["hypothesis"], "pots": pots, "signatures": signatures,
            "from": [f["group"] for f in groups if set(f["pots"]) & set(pots)], "again": pots != list(g["pots"]),
        })  # fmt: skip
    return pooled


def _merged(groups: Sequence[Mapping[str, Any]], checks: Mapping[str, pd.DataFrame]) -> dict[str, str]:
    """Each group's label -> the label of the group it is one with: the first (in the groups' order) whose
    correction brings every pot of it within noise and whose pots its own correction brings within
    noise; itself where none."""

    def explains_all(by: Mapping[str, Any], of: Mapping[str, Any]) -> bool:
        check = checks.get(by["group"])
        return check is not None and set(of["pots"]) <= set(explained_pots(check, by["pots"]))

    into = {g["group"]: g["group"] for g in groups}
    for i, g in enumerate(groups):
        first = next(
            (f for f in groups[:i] if into[f["group"]] == f["group"] and explains_all(f, g) and explains_all(g, f)),
            None,
        )
        if first is not None:
            into[g["group"]] = first["group"]
    return into
