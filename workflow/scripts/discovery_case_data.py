"""Simulate a shipped discovery case: trajectories with a hidden effect, plus measurement noise."""

from costa import runtime
from costa.data import write_trajectories
from costa.discover.pipeline import case_tables

runtime.configure(snakemake)
train, held_out = case_tables(snakemake.params.config, snakemake.wildcards.case)
write_trajectories(train, snakemake.output.train, {"case": snakemake.wildcards.case, "split": "train"})
write_trajectories(held_out, snakemake.output.held_out, {"case": snakemake.wildcards.case, "split": "held_out"})
