"""Concatenate the per-type tables; summarise with bootstrap intervals; check the paper's claims."""

import pandas as pd

from costa import runtime
from costa.claims import below_paper_size, evaluate_claims
from costa.summary import summary_table

log = runtime.configure(snakemake)
metrics = pd.concat([pd.read_parquet(p) for p in snakemake.input.metrics], ignore_index=True)
per_state = pd.concat([pd.read_parquet(p) for p in snakemake.input.per_state], ignore_index=True)
metrics.to_parquet(snakemake.output.metrics, index=False)
per_state.to_parquet(snakemake.output.per_state, index=False)
bootstrap = snakemake.params.bootstrap
summary = summary_table(metrics, bootstrap["resamples"], bootstrap["confidence"], snakemake.params.seed)
summary.to_csv(snakemake.output.summary, index=False)
claims = evaluate_claims(summary, below_paper_size(snakemake.params.size))
claims.to_csv(snakemake.output.claims, index=False)
log.info("claims:\n%s", claims[["key", "verdict", "evidence"]].to_string())
