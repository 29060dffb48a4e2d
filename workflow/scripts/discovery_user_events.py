"""Add the rates of your events (taps, AlF3 additions, alumina doses) to your record's inputs; note what they
hold that the model does not describe (anode changes)."""

from costa import runtime
from costa.data import write_trajectories
from costa.events import EVENT_KINDS, load_trajectories_with_events, not_modelled, read_events

log = runtime.configure(snakemake)
table = load_trajectories_with_events(snakemake.input.record, snakemake.input.events, snakemake.params.unlogged)
events = read_events(snakemake.input.events)
log.info(
    "%s: %s added to the inputs of %s",
    snakemake.input.events,
    ", ".join(f"{n} {k}" for k, n in events["kind"].value_counts().sort_index().items() if EVENT_KINDS[k].input),
    snakemake.input.record,
)
unmodelled = not_modelled(events)
if unmodelled:
    log.warning("%s: %s", snakemake.input.events, unmodelled)
provenance = {"source": snakemake.input.record, "events": snakemake.input.events, "not_modelled": unmodelled}
write_trajectories(table, snakemake.output.measurements, provenance)
