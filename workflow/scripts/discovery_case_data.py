"""Simulate a shipped discovery case: trajectories with a hidden effect, measured by a sensor set."""

from costa import runtime
from costa.data import write_trajectories
from costa.discover.cases.tables import case_tables

runtime.configure(snakemake)
sensors = snakemake.wildcards.get("sensors", "full")
train, held_out = case_tables(snakemake.params.config, snakemake.wildcards.case, sensors)
for table, path, split in ((train, snakemake.output.train, "train"), (held_out, snakemake.output.held_out, "held_out")):
    write_trajectories(table, path, {"case": snakemake.wildcards.case, "sensors": sensors, "split": split})
