"""Import one of your pots from its historian export and write its record (rule line_pot_import)."""

from pathlib import Path

from costa import runtime
from costa.data import write_trajectories
from costa.line.pots import Line, imported_pot

log = runtime.configure(snakemake)
config = snakemake.params.config
line = Line.from_config(config["line"])
pot = snakemake.wildcards.pot
record, kept = imported_pot(line, pot, config["simulation"]["dt_s"], Path(snakemake.output.report).parent)
files = line.historian_files(pot)
write_trajectories(record, snakemake.output.record, {"line": line.name, "pot": pot, "kept": kept, **files})
log.info("%s: %d steps imported from %s, kept %s", pot, len(record), files["export"], kept)
