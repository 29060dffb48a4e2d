"""Run discovery on one data set and write its findings and gap tables; in the closed loop (an input
``before``: a sparse run's findings), on its record with the top recommended channel added."""

import json
import sys

import pandas as pd

from costa import runtime
from costa.benchmark.closed_loop import loop_row, top_recommendation
from costa.data import channel_report, format_channel_report, load_trajectories, read_provenance
from costa.discover.cases.tables import with_channel
from costa.discover.findings import findings, findings_markdown
from costa.discover.pipeline import run_discovery, starting_model
from costa.physics import constants_table
from costa.sensors import Sensor

log = runtime.configure(snakemake)
config, case = snakemake.params.config, snakemake.params.name
start = starting_model(config, snakemake.params.starting_model)
train, held_out = load_trajectories(snakemake.input.train), load_trajectories(snakemake.input.held_out)
meta, declared = dict(snakemake.params.meta), dict(snakemake.params.declared_noise)
looped = "before" in snakemake.input.keys()
if looped:
    with open(snakemake.input.before) as handle:
        before = json.load(handle)
    added = top_recommendation(before)
    where = (snakemake.wildcards.case, snakemake.wildcards.sensors)
    if added is None:
        log.info("%s: %s, nothing recommended to add", case, before["outcome"])
        with open(snakemake.output.loop, "w") as handle:
            json.dump(loop_row(*where, before, None, None), handle, indent=1)
        with open(snakemake.output.findings, "w") as handle:
            json.dump(
                {"case": case, "outcome": "not run", "why": "the run before named or recommended nothing"}, handle
            )
        with open(snakemake.output.markdown, "w") as handle:
            handle.write(
                f"# {case}: the closed loop\n\nNot run: the run before ended {before['outcome']!r}, nothing to add.\n"
            )
        sys.exit(0)
    sensor = Sensor(added["channel"], added["every_s"], added["noise"])
    train, held_out = (with_channel(config, where[0], where[1], split, table, sensor)
                       for split, table in (("train", train), ("held_out", held_out)))  # fmt: skip
    declared[sensor.channel] = sensor.noise
    meta["data"] += f", and {sensor.channel} {sensor.interval} (noise {sensor.noise:g}) added: the closed loop"
    log.info("the closed loop: %s added", sensor.channel)
channels = channel_report(pd.concat([train, held_out], ignore_index=True))
constants = constants_table(config["physics"])
log.info("measured channels:\n%s", format_channel_report(channels))
log.info("the cell's constants:\n%s", constants.to_string(index=False))
# a sparse sensor set's first round, made by separate jobs (rules sensors_screen, sensors_fit)
first_round = (snakemake.input.screen, list(snakemake.input.fits)) if "screen" in snakemake.input.keys() else None
result = run_discovery(config, train, held_out, start, case, snakemake.input.train, declared, first_round)
provenance = read_provenance(snakemake.input.held_out)
for note in (provenance.get("how"), provenance.get("not_modelled")):  # your data: how split, what is not modelled
    if note:
        meta["data"] += f"; {note}"
found = findings(result, case, start, meta, channels, constants)
with open(snakemake.output.findings, "w") as handle:
    json.dump(found, handle, indent=1)
with open(snakemake.output.markdown, "w") as handle:
    handle.write(findings_markdown(found))
if looped:
    with open(snakemake.output.loop, "w") as handle:
        json.dump(loop_row(*where, before, added, found), handle, indent=1)
else:
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
