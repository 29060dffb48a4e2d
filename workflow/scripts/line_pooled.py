"""The second pass's groups, from the first pass's groups and each group's correction checked on the pots."""

import json
from pathlib import Path

import pandas as pd

from costa import runtime
from costa.line.pooled import pool_again

log = runtime.configure(snakemake)
groups = json.loads(Path(snakemake.input.groups).read_text())
checks = {Path(path).parent.name: pd.read_csv(path) for path in snakemake.input.checks}
pooled = pool_again(groups, checks)
Path(snakemake.output.groups).write_text(json.dumps(pooled, indent=1))
log.info("searched again: %s", [(g["group"], g["pots"]) for g in pooled if g["again"]] or "none")
