"""How much a drawn case's effect shows in the record a sensor set makes (costa.benchmark.signal)."""

import json

from costa import runtime
from costa.benchmark.signal import signal

log = runtime.configure(snakemake)
shown = signal(snakemake.params.config, snakemake.wildcards.case, snakemake.wildcards.sensors)
log.info("%s under %s: signal %.3g over %d samples", snakemake.wildcards.case, snakemake.wildcards.sensors,
         shown["signal"], shown["samples"])  # fmt: skip
with open(snakemake.output.signal, "w") as handle:
    json.dump(shown, handle, indent=1)
