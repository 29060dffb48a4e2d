"""Collect the closed loop of the benchmark's sparse cases: its table, its summary and its page."""

import json

from costa import runtime
from costa.benchmark.closed_loop import loop_markdown, loop_summary, loop_table

log = runtime.configure(snakemake)
rows = []
for path in snakemake.input.loops:
    with open(path) as handle:
        rows.append(json.load(handle))
table = loop_table(rows)
summary = loop_summary(table)
table.to_csv(snakemake.output.table, index=False)
summary.to_csv(snakemake.output.summary, index=False)
with open(snakemake.output.page, "w") as handle:
    handle.write(loop_markdown(summary, table, snakemake.params.split))
log.info("the closed loop:\n%s", summary.to_string(index=False))
