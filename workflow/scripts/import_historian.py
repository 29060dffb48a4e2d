"""One pot's historian export on the model's step (rule import_historian)."""

from pathlib import Path

from costa import runtime
from costa.config import historian_settings
from costa.historian import import_historian, read_tag_map
from costa.historian.report import write_import

log = runtime.configure(snakemake)
h = snakemake.params.historian
settings = historian_settings(h, snakemake.params.dt_s)
imported = import_historian(h["export"], read_tag_map(h["tags"]), settings, h["events"], h["lab"])
write_import(imported, Path(snakemake.output.record).parent, {"historian": dict(h)})
log.info("%d rows in %d trajectories", imported.report["rows"], imported.report["trajectories"])
