"""The line's page, from its table, its groups and each group's findings, first pass and pooled again."""

import json
from pathlib import Path

import pandas as pd

from costa import runtime
from costa.line.page import line_page
from costa.line.pots import Line

runtime.configure(snakemake)
line = Line.from_config(snakemake.params.config["line"])


def by_group(paths, read):
    """group -> the file each of its folders holds, read."""
    return {Path(path).parent.name: read(path) for path in paths}


def read_json(path):
    return json.loads(Path(path).read_text())


page = line_page(
    line, pd.read_csv(snakemake.input.table, keep_default_na=False), read_json(snakemake.input.groups),
    by_group(snakemake.input.findings, read_json), by_group(snakemake.input.checks, pd.read_csv),
    read_json(snakemake.input.pooled), by_group(snakemake.input.pooled_findings, read_json),
    by_group(snakemake.input.pooled_checks, pd.read_csv),
)  # fmt: skip
Path(snakemake.output.page).write_text(page)
