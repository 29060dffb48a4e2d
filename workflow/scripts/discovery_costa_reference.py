"""Train a CoSTA correction of the starting model on the same data; its gap on the held-out trajectories."""

from costa import runtime
from costa.data import load_trajectories
from costa.discover.pipeline import starting_model
from costa.discover.reference import costa_reference

runtime.configure(snakemake)
config = snakemake.params.config
start = starting_model(config, snakemake.params.starting_model)
gap = costa_reference(
    config,
    load_trajectories(snakemake.input.train),
    load_trajectories(snakemake.input.held_out),
    start,
    snakemake.wildcards.case,
)
gap.to_parquet(snakemake.output.gap, index=False)
