"""Draw a discovery case's figure."""

import json

import pandas as pd

from costa import runtime
from costa.plots import plot_discovery, save

runtime.configure(snakemake)
with open(snakemake.input.findings) as handle:
    found = json.load(handle)
gap = pd.concat([pd.read_parquet(snakemake.input.gap), pd.read_parquet(snakemake.input.costa)], ignore_index=True)
save(plot_discovery(found, gap), snakemake.output.png)
