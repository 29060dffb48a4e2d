"""One row per discovery case: hidden effect, flagged equations, what was named, gap before and after."""

from costa import runtime
from costa.discover.summary import discovery_summary

runtime.configure(snakemake)
discovery_summary(snakemake.input.findings, snakemake.input.costa).to_csv(snakemake.output.summary, index=False)
