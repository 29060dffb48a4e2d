"""The line's page, from its table, its groups and each group's findings."""

import json
from pathlib import Path

import pandas as pd

from costa import runtime
from costa.line.page import line_page
from costa.line.pots import Line

runtime.configure(snakemake)
line = Line.from_config(snakemake.params.config["line"])
groups = json.loads(Path(snakemake.input.groups).read_text())
findings = {Path(path).parent.name: json.loads(Path(path).read_text()) for path in snakemake.input.findings}
checks = {Path(path).parent.name: pd.read_csv(path) for path in snakemake.input.checks}
page = line_page(line, pd.read_csv(snakemake.input.table, keep_default_na=False), groups, findings, checks)
Path(snakemake.output.page).write_text(page)
