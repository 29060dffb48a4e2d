"""Split a user's measurements into trajectories to learn from and held-out ones; log what was measured."""

from costa import runtime
from costa.data import channel_report, format_channel_report, read_provenance, write_trajectories
from costa.discover.pipeline import split_held_out

log = runtime.configure(snakemake)
source = snakemake.input.measurements
train, held_out, how = split_held_out(source, snakemake.params.fraction, snakemake.params.unlogged)
log.info("%s: %s; measured channels:\n%s", source, how, format_channel_report(channel_report(train)))
carried = {"not_modelled": read_provenance(source).get("not_modelled", "")}  # the events' note, for the findings
write_trajectories(train, snakemake.output.train, {"source": source, "split": "train", "how": how} | carried)
write_trajectories(held_out, snakemake.output.held_out, {"source": source, "split": "held_out", "how": how} | carried)
