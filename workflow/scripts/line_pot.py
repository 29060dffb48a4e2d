"""Simulate one pot of a line and write its record."""

from costa import runtime
from costa.line.pots import Line, pot_record

log = runtime.configure(snakemake)
config = snakemake.params.config
line = Line.from_config(config["line"])
record = pot_record(config, line, snakemake.wildcards.pot)
record.to_parquet(snakemake.output.record, index=False)
log.info("%s: %d samples, hiding %s", snakemake.wildcards.pot, len(record), line.effects[snakemake.wildcards.pot])
