"""Stack the replicates' tables; their spread, bootstrap intervals and the paper's claims across them."""

import pandas as pd

from costa import runtime
from costa.replicates import aggregate_table, claim_verdicts, per_replicate_table, replicate_claims

log = runtime.configure(snakemake)


def stacked(paths, read):
    """The replicates' tables in one, with a replicate column (the inputs are in replicate order)."""
    return pd.concat([read(path).assign(replicate=index) for index, path in enumerate(paths)], ignore_index=True)


summaries = stacked(snakemake.input.summaries, pd.read_csv)
metrics = stacked(snakemake.input.metrics, pd.read_parquet)
resamples, confidence = snakemake.params.bootstrap["resamples"], snakemake.params.bootstrap["confidence"]
seed, out = snakemake.params.seed, snakemake.output
per_replicate_table(summaries).to_csv(out.per_replicate, index=False)
aggregate_table(summaries, metrics, resamples, confidence, seed).to_csv(out.aggregate, index=False)
claims = replicate_claims(summaries)
claims.to_csv(out.claims_by_replicate, index=False)
verdicts = claim_verdicts(claims, resamples, confidence, seed)
verdicts.to_csv(out.claims, index=False)
log.info("verdicts:\n%s", verdicts[["key", "verdict", "effects"]].to_string())
