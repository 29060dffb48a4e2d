"""Draw the training curves of every model type."""

import pandas as pd

from costa import runtime
from costa.plots import plot_training_curves, save

runtime.configure(snakemake)
losses = pd.concat([pd.read_parquet(path) for path in snakemake.input.losses], ignore_index=True)
save(plot_training_curves(losses), snakemake.output.png, snakemake.output.pdf)
