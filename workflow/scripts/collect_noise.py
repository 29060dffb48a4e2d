"""The noise study's table and figure from its rollouts' metrics."""

import pandas as pd

from costa import runtime
from costa.beyond import noise_table
from costa.plots import plot_noise_study, save

log = runtime.configure(snakemake)
metrics = pd.concat(
    [
        pd.read_parquet(path).assign(replicate=replicate, noise=level)
        for path, (replicate, level, _) in zip(snakemake.input.metrics, snakemake.params.runs, strict=True)
    ],
    ignore_index=True,
)
bootstrap = snakemake.params.bootstrap
table = noise_table(metrics, bootstrap["resamples"], bootstrap["confidence"], snakemake.params.seed)
table.to_csv(snakemake.output.table, index=False)
save(plot_noise_study(table), snakemake.output.png, snakemake.output.pdf)
log.info("noise study:\n%s", table[["noise", "model_type", "window", "blowups_mean", "median_mean"]].to_string())
