"""Simulate one data set and write it as Parquet."""

from costa import runtime
from costa.data import write_trajectories
from costa.datasets import simulate_split

log = runtime.configure(snakemake)
table, provenance = simulate_split(snakemake.params.config, snakemake.wildcards.split, snakemake.params.replicate)
write_trajectories(table, snakemake.output.data, provenance)
log.info(
    "wrote %d rows, %d trajectories, attempts %s",
    len(table),
    table["trajectory"].nunique(),
    provenance["simulation_attempts"],
)
