"""The whole Snakemake DAG on the smoke config, in a temporary directory; lint and format."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys

import nbformat
import pandas as pd
import pytest
from conftest import REPOSITORY, snakemake

SNAKEMAKE = [sys.executable, "-m", "snakemake", "--snakefile", str(REPOSITORY / "Snakefile")]


# the smoke config writes under results/smoke/ (config/smoke.yaml: output)
SMOKE_OUTPUTS = [
    "results/smoke/data/train.parquet", "results/smoke/data/test.parquet",
    "results/smoke/models/costa_sparse/instance1.pt", "results/smoke/models/ddm_dense/losses.parquet",
    "results/smoke/models/ddm_sparse/sparsity.parquet", "results/smoke/eval/pbm/metrics.parquet",
    "results/smoke/eval/metrics.parquet", "results/smoke/eval/summary.csv", "results/smoke/eval/claims.csv",
    "results/smoke/figures/datasets.png", "results/smoke/figures/datasets.pdf", "results/smoke/figures/training_curves.png",
    "results/smoke/figures/error_violins.png", "results/smoke/figures/blowups.pdf", "results/smoke/figures/rolling_forecast.png",
    "results/smoke/logs/simulate_train.log", "results/smoke/benchmarks/train_ddm_dense.tsv",
    "results/smoke/report/report.html", "results/smoke/report/report.ipynb",
]  # fmt: skip


def test_smoke_run_builds_every_target(smoke_run):
    for path in SMOKE_OUTPUTS:
        assert (smoke_run / path).stat().st_size > 0, path
    test = pd.read_parquet(smoke_run / "results/smoke/data/test.parquet")
    assert test["trajectory"].nunique() == 4 and test["step"].max() == 399
    metrics = pd.read_parquet(smoke_run / "results/smoke/eval/metrics.parquet")
    # (4 types x 2 instances + the PBM) x 4 trajectories x 3 windows x 2 definitions
    assert len(metrics) == (4 * 2 + 1) * 4 * 3 * 2


def test_report_is_rendered_without_errors(smoke_run):
    notebook = nbformat.read(smoke_run / "results/smoke/report/report.ipynb", as_version=4)
    outputs = [o for cell in notebook.cells if cell.cell_type == "code" for o in cell.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    html = (smoke_run / "results/smoke/report/report.html").read_text()
    assert "not assessed at this size" in html and "Provenance" in html and html.count("<img") >= 5
    assert "Robustness across replicates" in html and "from a single run" in html
    assert not re.findall(r'(?:src|href)="(?:https?:)?//', html)  # nothing from the network
    assert not re.search(r">[^<]*\bnan\b", html) and ">—<" in html  # a missing value is a dash


@pytest.mark.integration
def test_two_replicates_are_aggregated_plotted_and_reported(tmp_path):
    two = tmp_path / "two_replicates.yaml"
    two.write_text("replicates: 2\ndiscovery: {cases: []}\n")
    snakemake(tmp_path, "--configfile", str(REPOSITORY / "config" / "smoke.yaml"), str(two))
    for path in ["results/smoke/replicates/r1/eval/summary.csv", "results/smoke/replicates/r1/figures/rolling_forecast.png",
                 "results/smoke/replicates/blowups.png", "results/smoke/replicates/blowups.pdf"]:  # fmt: skip
        assert (tmp_path / path).stat().st_size > 0, path
    aggregate = pd.read_csv(tmp_path / "results/smoke/replicates/aggregate.csv")
    assert len(aggregate) == 5 * 3 and (aggregate.replicates == 2).all() and (aggregate.rollouts <= 8).all()
    claims = pd.read_csv(tmp_path / "results/smoke/replicates/claims.csv")
    assert claims.verdict.str.fullmatch("holds in [0-2] of 2 replicates").all()
    data = [pd.read_parquet(tmp_path / f"results/smoke/{rep}data/test.parquet") for rep in ("", "replicates/r1/")]
    assert not data[0]["x1"].equals(data[1]["x1"])  # each replicate has its own seeds
    html = (tmp_path / "results/smoke/report/report.html").read_text()
    assert "Robustness across replicates" in html and "of 2 replicates" in html and "from a single run" not in html


def test_second_run_has_nothing_to_do(smoke_run):
    result = snakemake(smoke_run, "--configfile", str(REPOSITORY / "config" / "smoke.yaml"), "--dry-run")
    assert "Nothing to be done" in result.stdout + result.stderr


def test_a_moved_run_has_nothing_to_do(smoke_run, tmp_path):
    """Snakemake records each job's inputs by path: the library's files are recorded relative to the
    run's folder, so that the folder moved (or copied) elsewhere is still up to date."""
    moved = tmp_path / "moved"
    shutil.copytree(smoke_run, moved, symlinks=True)
    result = snakemake(moved, "results/smoke/discovery/summary.csv", "--dry-run", "--configfile", "config/smoke.yaml")
    assert "Nothing to be done" in result.stdout + result.stderr, result.stdout[-3000:]


def test_bad_config_stops_with_the_key_and_keeps_results(smoke_run):
    data = smoke_run / "results/smoke/data/train.parquet"
    before = data.read_bytes()
    bad = smoke_run / "bad.yaml"
    bad.write_text("simulation:\n  train_trajectories: -3\n")
    result = snakemake(smoke_run, "--configfile", str(REPOSITORY / "config" / "smoke.yaml"), str(bad), check=False)
    assert result.returncode != 0
    assert "invalid config at 'simulation.train_trajectories': -3 is less than the minimum of 1" in result.stderr
    assert data.read_bytes() == before


def test_lint_has_nothing_to_say():
    result = subprocess.run([*SNAKEMAKE, "--lint"], capture_output=True, text=True, cwd=REPOSITORY)
    assert result.returncode == 0 and "Congratulations" in result.stdout + result.stderr, result.stdout + result.stderr


def test_snakemake_files_are_formatted():
    files = [str(REPOSITORY / "Snakefile"), *map(str, sorted((REPOSITORY / "workflow" / "rules").glob("*.smk")))]
    result = subprocess.run([sys.executable, "-m", "snakefmt", "--check", *files], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


@pytest.mark.integration
def test_beyond_config_adds_the_discovered_model_the_noise_study_and_the_stable_variant(tmp_path):
    """config/beyond.yaml's pieces on the smoke sizes: new types, the discovered model's rows, noise levels."""
    tiny = tmp_path / "tiny_beyond.yaml"
    tiny.write_text(
        "training:\n  model_types:\n"
        "    costa_bounded: {target: costa, l1_lambda: 1.0e-4, source_bound: {margin: 0.0, inputs: true}}\n"
        "    costa_smooth: {target: costa, l1_lambda: 1.0e-4, savgol: {window: 11, order: 2}}\n"
        "beyond: {discovered_model: true, noise: {levels: [0, 5], model_types: [costa_smooth]}}\n"
        "figures: {rolling_forecast_types: [costa_sparse, costa_bounded]}\n"
        "discovery: {cases: []}\n"
    )
    snakemake(tmp_path, "--configfile", str(REPOSITORY / "config" / "smoke.yaml"), str(tiny))
    results = tmp_path / "results/smoke"
    metrics = pd.read_parquet(results / "eval/metrics.parquet")
    discovered = metrics[metrics.model_type == "discovered"]
    # one rollout per test trajectory, like the PBM: 4 trajectories x 3 windows x 2 definitions
    assert len(discovered) == 4 * 3 * 2 and (discovered.instance == 0).all()
    assert len(metrics) == (6 * 2 + 2) * 4 * 3 * 2
    noisy = pd.read_parquet(results / "noise/5/data/train.parquet")
    clean = pd.read_parquet(results / "data/train.parquet")
    assert noisy["u2"].equals(clean["u2"]) and not noisy["x6"].equals(clean["x6"])
    assert (results / "noise/5/eval/discovered/findings.json").stat().st_size > 0
    noise = pd.read_csv(results / "beyond/noise.csv")
    assert set(noise.noise) == {0.0, 5.0} and set(noise.model_type) == {"costa_smooth", "discovered"}
    assert len(noise) == 2 * 2 * 3 and (results / "beyond/noise.png").stat().st_size > 0
    html = (results / "report/report.html").read_text()
    assert "The discovered model on the paper" in html and "A stable CoSTA" in html and "No noise study" not in html
