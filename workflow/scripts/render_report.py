"""Execute the report notebook on this run's results and render it to HTML."""

from pathlib import Path

from costa import runtime
from costa.report import git_commit, render_notebook

runtime.configure(snakemake)
inputs = {key: value for key, value in snakemake.input.items() if key not in ("notebook", "code")}
inputs = {
    k: [str(Path(p).resolve()) for p in v] if isinstance(v, list) else str(Path(v).resolve()) for k, v in inputs.items()
}
render_notebook(
    snakemake.input.notebook,
    snakemake.output.notebook,
    snakemake.output.html,
    {"inputs": inputs, "config": snakemake.params.config, "commit": git_commit(snakemake.params.repository)},
)
