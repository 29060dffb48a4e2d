"""The benchmark's table, rates, recall curve, figure and page, from every drawn case's findings and signal."""

from pathlib import Path

import pandas as pd

from costa import runtime
from costa.benchmark.score import case_table, rates, rates_markdown, recall_by_signal
from costa.plots import plot_recall_by_signal, save

runtime.configure(snakemake)


def seconds(findings: str) -> float:
    """Seconds of every job of a case under a sensor set (its benchmark files beside its findings)."""
    jobs = sorted((Path(findings).parent / "benchmarks").glob("*.tsv"))
    return float(sum(pd.read_csv(job, sep="\t")["s"].iloc[0] for job in jobs if job.stem != "costa_reference"))


params = snakemake.params
cases = case_table(
    snakemake.input.findings, snakemake.input.signals, params.sensors, [seconds(f) for f in snakemake.input.findings]
)
cases.to_csv(snakemake.output.summary, index=False)
table = rates(cases, params.order)
table.to_csv(snakemake.output.rates, index=False)
curve = recall_by_signal(cases, params.bins)
curve.to_csv(snakemake.output.curve, index=False)
save(plot_recall_by_signal(curve, cases), snakemake.output.figure)
Path(snakemake.output.page).write_text(
    "# The discovery benchmark\n\n" + rates_markdown(table, params.split, params.size)
)
