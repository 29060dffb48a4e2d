"""A group's one correction checked on every pot that disagrees: does one coefficient hold for all
of the group's pots, and which other pots does it explain?

Discovery on a group fits one closed form on its pots together.  Each pot that the screen flagged is
then filtered again alone under the group's corrected model, and each measured channel tested as
the screen tests it (:func:`costa.discover.sparse.rounds.channel_tests`); under the starting model
the screen's own tests stand (:func:`screened`: the same filter, not run again).
A pot of the group that the correction still leaves beyond noise differs from the rest of the group:
its coefficient (the effect stronger or weaker there) or something more missing in it.  A pot of
another group that the correction brings within noise misses the same physics: the pots' one-by-one
screens, on a few days each, could not tell.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import pandas as pd

from ..discover.core.settings import DiscoverySettings
from ..discover.sparse.pipeline import observations
from ..discover.sparse.rounds import channel_tests
from ..physics import CellModel

__all__ = ["check_pots", "differing_pots", "explained_pots", "screened"]


def check_pots(
    models: Mapping[str, CellModel], records: Mapping[str, pd.DataFrame], declared_noise: Mapping[str, float],
    settings: DiscoverySettings,
) -> pd.DataFrame:  # fmt: skip
    """One row per pot (``records``: pot -> its record), model (``models``: label -> model) and measured
    channel: chi2/dof of its innovations and whether it disagrees beyond noise (``flagged``)."""
    rows = []
    for pot, record in records.items():
        for label, model in models.items():
            obs = observations(record, declared_noise, pot).with_start(model)
            tests, _ = channel_tests(model, obs, settings, backward=False)
            rows += [
                {"pot": pot, "model": label, "channel": t.channel, "chi2_per_dof": round(t.chi2_per_dof, 4),
                 "flagged": bool(t.flagged)}
                for t in tests
            ]  # fmt: skip
    return pd.DataFrame(rows)


def screened(screens: Mapping[str, Mapping], model: str = "start") -> pd.DataFrame:
    """The rows :func:`check_pots` gives under the model the pots were screened with, read from their
    screens (pot -> :func:`.screen.screen_pot`), labelled ``model``."""
    return pd.DataFrame([
        {"pot": pot, "model": model, "channel": c["channel"], "chi2_per_dof": c["chi2_per_dof"], "flagged": c["flagged"]}
        for pot, screen in screens.items() for c in screen["channels"]
    ])  # fmt: skip


def differing_pots(checked: pd.DataFrame, model: str = "corrected", pots: Sequence[str] | None = None) -> list[str]:
    """The pots (of ``pots``, or every one checked) that ``model`` leaves disagreeing in some channel, in their order."""
    rows = checked[checked["model"] == model]
    flagged = rows.groupby("pot", sort=False)["flagged"].any()
    return [pot for pot, f in flagged.items() if f and (pots is None or pot in pots)]


def explained_pots(checked: pd.DataFrame, pots: Sequence[str]) -> list[str]:
    """The pots checked, other than ``pots`` (the group's), that disagree with the starting model and
    that the group's correction brings within noise in every channel."""
    start, corrected = (set(differing_pots(checked, model)) for model in ("start", "corrected"))
    return [pot for pot in dict.fromkeys(checked["pot"]) if pot not in pots and pot in start - corrected]
