"""Draw the violin and blow-up figures for both metric definitions."""

import pandas as pd

from costa import runtime
from costa.plots import plot_blowups, plot_error_violins, save

runtime.configure(snakemake)
metrics = pd.read_parquet(snakemake.input.metrics)
out = snakemake.output
save(plot_error_violins(metrics, "coded"), out.violin, out.violin_pdf)
save(plot_blowups(metrics, "coded"), out.blowups, out.blowups_pdf)
save(plot_error_violins(metrics, "printed"), out.violin_printed)
save(plot_blowups(metrics, "printed"), out.blowups_printed)
