"""Screen one pot of a line with the starting model."""

import json

from costa import runtime
from costa.data import load_trajectories
from costa.discover.pipeline import settings_from_config, starting_model
from costa.line.pots import Line
from costa.line.screen import screen_pot

log = runtime.configure(snakemake)
config = snakemake.params.config
line = Line.from_config(config["line"])
model = starting_model(config, line.starting_model)
record = load_trajectories(snakemake.input.record)
screen = screen_pot(model, record, line.declared_noise(config), settings_from_config(config), snakemake.input.record)
with open(snakemake.output.screen, "w") as handle:
    json.dump(screen, handle, indent=1)
log.info("%s: %s in %.1f s", snakemake.wildcards.pot, screen["signature"] or "agrees", screen["seconds"])
