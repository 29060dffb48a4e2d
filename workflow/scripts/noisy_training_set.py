"""Add measurement noise to a replicate's training set (the test set stays clean)."""

from costa import runtime
from costa.beyond import noisy_table
from costa.data import load_trajectories, write_trajectories

log = runtime.configure(snakemake)
level = float(snakemake.wildcards.level)
table = noisy_table(load_trajectories(snakemake.input.train), level, snakemake.params.seed, snakemake.params.replicate)
write_trajectories(
    table,
    snakemake.output.train,
    {"source": snakemake.input.train, "noise_percent_of_state_std": level, "replicate": snakemake.params.replicate},
)
log.info("added %g %% noise to %d trajectories", level, table["trajectory"].nunique())
