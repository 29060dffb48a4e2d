"""Add the rates of your events (taps, AlF3 additions, alumina doses) to your record's inputs."""

from costa import runtime
from costa.data import write_trajectories
from costa.events import load_trajectories_with_events, read_events

log = runtime.configure(snakemake)
table = load_trajectories_with_events(snakemake.input.record, snakemake.input.events, snakemake.params.unlogged)
events = read_events(snakemake.input.events)
log.info(
    "%s: %s added to the inputs of %s",
    snakemake.input.events,
    ", ".join(f"{n} {kind}" for kind, n in events["kind"].value_counts().sort_index().items()),
    snakemake.input.record,
)
write_trajectories(
    table, snakemake.output.measurements, {"source": snakemake.input.record, "events": snakemake.input.events}
)
