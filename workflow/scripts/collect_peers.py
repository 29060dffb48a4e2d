"""One table of every case and method."""

import pandas as pd

from costa import runtime

runtime.configure(snakemake)
pd.concat([pd.read_csv(path) for path in snakemake.input.rows], ignore_index=True).to_csv(
    snakemake.output.summary, index=False
)
