"""One row per shipped case and sensor set: what was named, its closed form, the gap."""

from costa import runtime
from costa.discover.summary import sensors_summary

runtime.configure(snakemake)
sensors_summary(snakemake.input.findings, snakemake.params.sensors).to_csv(snakemake.output.summary, index=False)
