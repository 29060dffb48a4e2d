"""A group's pots pooled into one data set and split into pots to learn from and held out."""

from costa import runtime
from costa.data import load_trajectories, write_trajectories
from costa.discover.pipeline import split_held_out
from costa.line.groups import pooled_record

log = runtime.configure(snakemake)
line = snakemake.params.config["line"]
pooled = pooled_record([load_trajectories(path) for path in snakemake.input.records])
write_trajectories(pooled, snakemake.output.record, {"source": list(snakemake.input.records)})
train, held_out, how = split_held_out(snakemake.output.record, line["held_out_fraction"])
provenance = {"source": snakemake.output.record, "how": how}
write_trajectories(train, snakemake.output.train, {**provenance, "split": "train"})
write_trajectories(held_out, snakemake.output.held_out, {**provenance, "split": "held_out"})
log.info("group %s: %s", snakemake.wildcards.group, how)
