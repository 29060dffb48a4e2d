"""Run discovery on one data set and write its findings and gap tables."""

import json

import pandas as pd

from costa import runtime
from costa.data import channel_report, format_channel_report, load_trajectories, read_provenance
from costa.discover.findings import findings, findings_markdown
from costa.discover.pipeline import run_discovery, starting_model
from costa.physics import constants_table

log = runtime.configure(snakemake)
config, case = snakemake.params.config, snakemake.params.name
start = starting_model(config, snakemake.params.starting_model)
train, held_out = load_trajectories(snakemake.input.train), load_trajectories(snakemake.input.held_out)
channels = channel_report(pd.concat([train, held_out], ignore_index=True))
constants = constants_table(config["physics"])
log.info("measured channels:\n%s", format_channel_report(channels))
log.info("the cell's constants:\n%s", constants.to_string(index=False))
# a sparse sensor set's first round, made by separate jobs (rules sensors_screen, sensors_fit)
first_round = (snakemake.input.screen, list(snakemake.input.fits)) if "screen" in snakemake.input.keys() else None
result = run_discovery(
    config, train, held_out, start, case, snakemake.input.train, snakemake.params.declared_noise, first_round
)
meta = dict(snakemake.params.meta)
provenance = read_provenance(snakemake.input.held_out)
for note in (provenance.get("how"), provenance.get("not_modelled")):  # your data: how split, what is not modelled
    if note:
        meta["data"] += f"; {note}"
found = findings(result, case, start, meta, channels, constants)
with open(snakemake.output.findings, "w") as handle:
    json.dump(found, handle, indent=1)
with open(snakemake.output.markdown, "w") as handle:
    handle.write(findings_markdown(found))
result.gap.to_parquet(snakemake.output.gap, index=False)
result.per_state.to_parquet(snakemake.output.per_state, index=False)
log.info(
    "%s: %s, named %s in %.1f s; shrink %s",
    case,
    found["outcome"],
    found["named"],
    result.seconds,
    found["gap"]["shrink"],
)
