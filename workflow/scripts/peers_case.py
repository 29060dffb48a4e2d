"""Run PySINDy and the UDE recipe on one case and score them beside this workflow's findings."""

import json

from costa import runtime
from costa.data import load_trajectories
from costa.peers.compare import compare_case

log = runtime.configure(snakemake)
case = snakemake.wildcards.case
found = json.loads(open(snakemake.input.findings).read())
train, held_out = load_trajectories(snakemake.input.train), load_trajectories(snakemake.input.held_out)
rows, details = compare_case(snakemake.params.config, case, train, held_out, found)
rows.to_csv(snakemake.output.rows, index=False)
with open(snakemake.output.details, "w") as handle:
    json.dump(details, handle, indent=1)
log.info("%s:\n%s", case, rows.drop(columns=["correction"]).to_string(index=False))
