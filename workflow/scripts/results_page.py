"""This run's result tables as one Markdown page (docs/results.md is this page from the default run)."""

import pandas as pd

from costa import runtime
from costa.kernels import kernel_provenance
from costa.paper import beside_the_paper


def markdown(table: pd.DataFrame) -> str:
    """A Markdown table; a missing value as "—", a "|" inside a cell escaped."""
    escaped = table.apply(lambda c: c.str.replace("|", "\\|") if pd.api.types.is_string_dtype(c) else c)
    return escaped.astype(object).where(escaped.notna(), None).to_markdown(index=False, floatfmt="g", missingval="—")


log = runtime.configure(snakemake)
config = snakemake.params.config
summary = pd.read_csv(snakemake.input.summary)
lines = [
    "## The paper's experiment (default run)",
    "",
    f"Written by the workflow's `results_page` rule from `{snakemake.input.summary}` (seed {config['seed']}, "
    f"{config['training']['instances']} instances x {config['simulation']['test_trajectories']} test trajectories "
    "per network type). Coded metric AN-RFMSE, lower is better; a rollout blows up in a window when its error "
    f"exceeds {config['evaluation']['blowup_threshold']:g} there. Intervals: 95 % bootstrap over instances "
    "(PBM: over trajectories). The paper's values are read off its figures (docs/model.md §7).",
    "",
    markdown(beside_the_paper(summary[summary.definition == "coded"])),
    "",
    "Computed with " + "; ".join(f"{key} {value}" for key, value in kernel_provenance().items()) + ".",
]
if snakemake.input.discovery:
    discovery = pd.read_csv(snakemake.input.discovery[0])
    columns = [c for c in snakemake.params.discovery_columns if c in discovery.columns]
    lines += ["", "## Discovery: the shipped hidden-effect cases", "", markdown(discovery[columns])]
with open(snakemake.output.page, "w") as page:
    page.write("\n".join(lines) + "\n")
log.info("wrote %s", snakemake.output.page)
