"""Split a user's measurements into trajectories to learn from and held-out ones; log what was measured."""

from costa import runtime
from costa.data import channel_report, format_channel_report, write_trajectories
from costa.discover.pipeline import split_held_out

log = runtime.configure(snakemake)
train, held_out = split_held_out(snakemake.input.measurements, snakemake.params.fraction, snakemake.params.unlogged)
log.info(
    "%s: %d trajectories to learn from, %d held out; measured channels:\n%s",
    snakemake.input.measurements,
    train["trajectory"].nunique(),
    held_out["trajectory"].nunique(),
    format_channel_report(channel_report(train)),
)
write_trajectories(train, snakemake.output.train, {"source": snakemake.input.measurements, "split": "train"})
write_trajectories(held_out, snakemake.output.held_out, {"source": snakemake.input.measurements, "split": "held_out"})
