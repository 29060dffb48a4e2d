"""A group's one correction checked on every pot that disagrees with the starting model, each alone."""

import json
from pathlib import Path

import pandas as pd

from costa import runtime
from costa.data import load_trajectories
from costa.discover.findings import corrected_model
from costa.discover.pipeline import settings_from_config, starting_model
from costa.line.check import check_pots, differing_pots, explained_pots, screened
from costa.line.pots import Line

log = runtime.configure(snakemake)
config = snakemake.params.config
line = Line.from_config(config["line"])
start = starting_model(config, line.starting_model)
found = json.loads(Path(snakemake.input.findings).read_text())
pots, members = snakemake.params.pots, snakemake.params.members
records = {pot: load_trajectories(path) for pot, path in zip(pots, snakemake.input.records, strict=True)}
screens = {pot: json.loads(Path(path).read_text()) for pot, path in zip(pots, snakemake.input.screens, strict=True)}
models = {"corrected": corrected_model(found, start)}  # under the starting model the screens' tests stand
checked = pd.concat(
    [screened(screens), check_pots(models, records, line.declared_noise(config), settings_from_config(config))],
    ignore_index=True,
)
checked = checked.sort_values("pot", key=lambda pot: pot.map(pots.index), kind="stable", ignore_index=True)
checked.insert(1, "member", checked["pot"].isin(members))
checked.to_csv(snakemake.output.pots, index=False)
log.info(
    "group %s: the correction leaves %s of its pots disagreeing and explains %s of the others",
    snakemake.wildcards.group,
    differing_pots(checked, pots=members) or "none",
    explained_pots(checked, members) or "none",
)
