"""The line's table, its figure and its groups, from every pot's screen."""

import json
from pathlib import Path

from costa import runtime
from costa.discover.pipeline import settings_from_config
from costa.line.groups import group_pots, line_table
from costa.line.pots import Line
from costa.plots import plot_line, save

log = runtime.configure(snakemake)
config = snakemake.params.config
line = Line.from_config(config["line"])
screens = {Path(path).parent.name: json.loads(Path(path).read_text()) for path in snakemake.input.screens}
table = line_table(screens, line.effects)
groups = group_pots(screens, settings_from_config(config).equivalence)
table.to_csv(snakemake.output.table, index=False)
Path(snakemake.output.groups).write_text(json.dumps(groups, indent=1))
save(plot_line(table, groups), snakemake.output.figure)
log.info(
    "%d pots, %d groups: %s", len(screens), len(groups), [(g["group"], g["hypothesis"], g["pots"]) for g in groups]
)
