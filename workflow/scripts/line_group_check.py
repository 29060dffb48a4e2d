"""A group's one correction checked on every pot that disagrees with the starting model, each alone."""

import json
from pathlib import Path

from costa import runtime
from costa.data import load_trajectories
from costa.discover.findings import corrected_model
from costa.discover.pipeline import settings_from_config, starting_model
from costa.line.check import check_pots, differing_pots, explained_pots
from costa.line.pots import Line

log = runtime.configure(snakemake)
config = snakemake.params.config
line = Line.from_config(config["line"])
start = starting_model(config, line.starting_model)
found = json.loads(Path(snakemake.input.findings).read_text())
records = {
    pot: load_trajectories(path) for pot, path in zip(snakemake.params.pots, snakemake.input.records, strict=True)
}
models = {"start": start, "corrected": corrected_model(found, start)}
checked = check_pots(models, records, line.declared_noise(config), settings_from_config(config))
checked.insert(1, "member", checked["pot"].isin(snakemake.params.members))
checked.to_csv(snakemake.output.pots, index=False)
members = snakemake.params.members
log.info(
    "group %s: the correction leaves %s of its pots disagreeing and explains %s of the others",
    snakemake.wildcards.group,
    differing_pots(checked, pots=members) or "none",
    explained_pots(checked, members) or "none",
)
