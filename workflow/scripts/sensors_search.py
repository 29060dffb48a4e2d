"""The first round of a sparse search as jobs: the screen (rule sensors_screen) or one share of its fits (sensors_fit)."""

from costa import runtime
from costa.data import load_trajectories
from costa.discover.pipeline import discovery_route, search_settings, starting_model
from costa.discover.sparse.pipeline import fit_first_round, screen_first_round

log = runtime.configure(snakemake)
config, name = snakemake.params.config, snakemake.params.name
start = starting_model(config, snakemake.params.starting_model)
train = load_trajectories(snakemake.input.train)
route = discovery_route(config, name, [train, load_trajectories(snakemake.input.held_out)])
settings, noise = search_settings(config, name, route), snakemake.params.declared_noise
if snakemake.rule == "sensors_screen":
    screen_first_round(train, start, settings, noise, snakemake.input.train, snakemake.output.screen)
else:
    job, jobs = int(snakemake.wildcards.job), int(snakemake.wildcards.jobs)
    fit_first_round(
        train, start, settings, noise, snakemake.input.train, snakemake.input.screen, job, jobs, snakemake.output.fits
    )
log.info("%s done", snakemake.rule)
