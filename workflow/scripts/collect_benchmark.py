"""The benchmark's table, rates, recall curve, figure and page, from every drawn case's findings and signal."""

from pathlib import Path

import pandas as pd

from costa import runtime
from costa.benchmark.score import (
    case_table,
    peer_rates,
    peers_markdown,
    projected_hours,
    rates,
    rates_markdown,
    recall_by_signal,
    strong_by_kind,
    strong_by_kind_markdown,
)
from costa.benchmark.truth_listed import truth_listed_table
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
# split and size travel with the rates: a test run's file is what the package publishes (docs/discovery.md)
table.assign(split=params.split, size=params.size).to_csv(snakemake.output.rates, index=False)
curve = recall_by_signal(cases, params.bins)
curve.to_csv(snakemake.output.curve, index=False)
save(plot_recall_by_signal(curve, cases), snakemake.output.figure)
by_kind = strong_by_kind(cases)
by_kind.to_csv(snakemake.output.by_kind, index=False)
# a dev run's (size: calibration) is what the package publishes: the chances of a right name (costa.discover.rates)
listed = truth_listed_table(snakemake.input.findings, params.sensors)
listed.assign(split=params.split, size=params.size).to_csv(snakemake.output.truth_listed, index=False)
page = "# The discovery benchmark\n\n" + rates_markdown(table, params.split, params.size)
page += "\n" + strong_by_kind_markdown(by_kind)
page += "\nEach size at this run's job seconds a case (2 cores run two jobs at a time; the SLURM profile as many as it is given):\n\n"
page += projected_hours(table, {size: chosen["sensors"] for size, chosen in params.sizes.items()}, (2, 16, 64))
if snakemake.input.peers:
    peers = peer_rates(pd.concat(map(pd.read_csv, snakemake.input.peers), ignore_index=True))
    page += f"\n## Against its peers, on the full set's first {len(snakemake.input.peers)} cases\n\n"
    page += peers_markdown(peers)
else:
    peers = pd.DataFrame(columns=["method"])
peers.to_csv(snakemake.output.peers, index=False)
Path(snakemake.output.page).write_text(page)
