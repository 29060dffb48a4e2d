"""Split a user's measurements into trajectories to learn from and held-out ones."""

from costa import runtime
from costa.data import write_trajectories
from costa.discover.pipeline import split_held_out

runtime.configure(snakemake)
train, held_out = split_held_out(snakemake.input.measurements, snakemake.params.fraction)
write_trajectories(train, snakemake.output.train, {"source": snakemake.input.measurements, "split": "train"})
write_trajectories(held_out, snakemake.output.held_out, {"source": snakemake.input.measurements, "split": "held_out"})
