"""The smoke workflow and a small pot line through a real SLURM (one node on localhost) give the local runs' bytes.

Runs where Debian's ``slurm-wlm`` and ``munge`` are installed and the tests run as root
(CI installs them), else skips with the reason. The README's cluster command runs as
written, plus the flags that only this throw-away cluster needs, for the two tables that
gather every data, model, metric and finding file the comparison covers (the figures and
the report, 10 of the 29 jobs, are left out: they add a minute of job start-ups and no
compared byte).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import pytest
from conftest import SMOKE_COMMAND, TIMINGS, TINY_LINE_TARGET, repository_copy, result_hashes, run_command
from local_slurm import local_slurm, missing_prerequisites

pytestmark = [
    pytest.mark.integration,
    pytest.mark.slurm,
    pytest.mark.skipif(missing_prerequisites() is not None, reason=f"no local SLURM: {missing_prerequisites()}"),
]

#: The README's command ("On a cluster"), on the smoke config.
CLUSTER_COMMAND = "snakemake --workflow-profile workflow/profiles/slurm --configfile config/smoke.yaml"
#: The gathering tables of the evaluation and the discovery: every compared file is upstream of them.
COMPARED_TARGETS = "results/smoke/eval/summary.csv results/smoke/discovery/summary.csv"
#: This cluster keeps no accounting database (so no sacct and no accounts), and its jobs
#: take seconds: poll squeue every second from the first instead of sacct every 10 s after 40 s.
TEST_CLUSTER_FLAGS = (
    "--slurm-status-command squeue --slurm-no-account --slurm-init-seconds-before-status-checks 1"
    " --seconds-between-status-checks 1"
)


def test_smoke_run_on_slurm_matches_the_local_run(smoke_run, tmp_path):
    workdir = repository_copy(tmp_path / "repository")
    # slurmd's sockets live under the cluster's folder, and a Unix socket's path holds at most 108
    # bytes: pytest's tmp_path (longer under pytest-xdist) can exceed it, so the cluster sits in /tmp
    with tempfile.TemporaryDirectory(prefix="costa-slurm-") as short, local_slurm(Path(short)) as env:
        started = time.perf_counter()
        command = CLUSTER_COMMAND.replace(" --configfile", f" {COMPARED_TARGETS} --configfile")
        result = run_command(workdir, f"{command} {TEST_CLUSTER_FLAGS}", env=env, timeout=1200)
        TIMINGS["slurm smoke run"] = time.perf_counter() - started
    assert result.returncode == 0, f"{result.stdout[-3000:]}\n{result.stderr[-8000:]}"
    assert "slurm" in result.stderr.lower()  # the jobs went through sbatch, not the local executor
    local, cluster = result_hashes(smoke_run), result_hashes(workdir)
    assert len(cluster) > 40 and cluster == local
    print(
        f"\nsmoke workflow wall time: local {TIMINGS.get('local smoke run', float('nan')):.0f} s "
        f"({SMOKE_COMMAND}), SLURM {TIMINGS['slurm smoke run']:.0f} s ({CLUSTER_COMMAND})"
    )


def test_a_small_line_on_slurm_matches_the_local_run(tiny_line_run, tmp_path):
    """The line's jobs (a pot's record and screen, the checkpoint that groups the pots, a group's data,
    discovery and check, the page) each an sbatch job: the same screens, groups, findings and checks."""
    workdir = repository_copy(tmp_path / "repository")
    (workdir / "tinyline.yaml").write_text((tiny_line_run / "tinyline.yaml").read_text())
    with tempfile.TemporaryDirectory(prefix="costa-slurm-") as short, local_slurm(Path(short)) as env:
        started = time.perf_counter()
        command = CLUSTER_COMMAND.replace(
            " --configfile config/smoke.yaml", f" {TINY_LINE_TARGET} --configfile tinyline.yaml"
        )
        result = run_command(workdir, f"{command} {TEST_CLUSTER_FLAGS}", env=env, timeout=1200)
        TIMINGS["slurm tiny line"] = time.perf_counter() - started
    assert result.returncode == 0, f"{result.stdout[-3000:]}\n{result.stderr[-8000:]}"
    assert "slurm" in result.stderr.lower()
    local, cluster = (result_hashes(w, "results/tinyline") for w in (tiny_line_run, workdir))
    assert len(cluster) > 10 and cluster == local
    assert (workdir / TINY_LINE_TARGET).read_text() == (tiny_line_run / TINY_LINE_TARGET).read_text()
    print(f"\ntiny line wall time: local {TIMINGS['local tiny line']:.0f} s, SLURM {TIMINGS['slurm tiny line']:.0f} s")
