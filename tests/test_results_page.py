"""The result tables are written by the workflow, not typed: the smoke run's page holds
its summary's numbers, and the README's headline numbers are the default run's page's."""

from __future__ import annotations

import itertools

import pandas as pd
from conftest import REPOSITORY

DEFAULT_RUN = "## The paper's experiment (default run)"
# README headline row label -> the model's label in the results page
HEADLINES = {
    "PBM (ablated)": "PBM (ablated)",
    'DDM, ℓ1-regularised ("sparse")': "DDM sparse",
    'CoSTA, ℓ1-regularised ("sparse")': "CoSTA sparse",
}


def first_table(markdown: str, heading: str) -> pd.DataFrame:
    """The first pipe table after ``heading`` in a Markdown text, as strings (no escaped pipes)."""
    lines = markdown.split(heading, 1)[1].splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("|"))
    rows = itertools.takewhile(lambda line: line.startswith("|"), lines[start:])
    header, _alignment, *body = [[cell.strip() for cell in row.strip().strip("|").split("|")] for row in rows]
    return pd.DataFrame(body, columns=header)


def test_the_smoke_runs_results_page_holds_its_summarys_numbers(smoke_run):
    page = (smoke_run / "results/smoke/results.md").read_text()
    table = first_table(page, "## The paper's experiment")
    summary = pd.read_csv(smoke_run / "results/smoke/eval/summary.csv")
    coded = summary[summary.definition == "coded"]
    assert table["blow-ups"].str.split().str[0].astype(int).tolist() == coded.blowups.tolist()
    assert len(table) == len(coded) and "torch kernel ISA AVX2" in page


def test_the_readmes_headline_numbers_are_the_default_runs_page():
    table = first_table((REPOSITORY / "docs/results.md").read_text(), DEFAULT_RUN).set_index(["model", "window"])
    readme = (REPOSITORY / "README.md").read_text()
    for headline, model in HEADLINES.items():
        row = table.loc[(model, "long")]
        median, blowups = row["median AN-RFMSE"].split()[0], row["blow-ups"].split()[0]
        assert f"| {headline} | {median} | {blowups} of {row['rollouts']} |" in readme, headline
