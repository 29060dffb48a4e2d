"""Crash and resume: a smoke run killed with SIGKILL during training completes, on rerun, to the same bytes.

SIGKILL leaves what a power cut or the out-of-memory killer leaves: Snakemake's lock,
and the outputs of the killed jobs marked incomplete in .snakemake/incomplete, possibly
half written. The README's two commands resume (run here on the smoke config):
``--unlock`` removes the dead run's lock, ``--rerun-incomplete`` redoes the jobs it cut off.
"""

from __future__ import annotations

import base64
import os
import signal
import subprocess
import time

import pytest
from conftest import SMOKE_COMMAND, on_smoke, repository_copy, result_hashes, run_command, shell_environment

pytestmark = pytest.mark.integration

#: The README's commands after a crash.
UNLOCK, RESUME = "snakemake --cores 2 --unlock", "snakemake --cores 2 --rerun-incomplete"


def _training_in_progress(workdir) -> bool:
    """A training job has started (its log exists) and has not written its models yet."""
    for log in (workdir / "results/smoke/logs").glob("train_*.log"):
        if not (workdir / "results/smoke/models" / log.stem.removeprefix("train_") / "losses.parquet").exists():
            return True
    return False


def _marked_incomplete(workdir) -> list[str]:
    """The outputs Snakemake marked incomplete (one marker file per output, named by its base64-encoded path)."""
    markers = (workdir / ".snakemake/incomplete").rglob("*")
    return sorted(base64.b64decode(m.name).decode() for m in markers if m.is_file() and m.name != "migration_underway")


def test_a_run_killed_during_training_resumes_to_the_same_bytes(smoke_run, tmp_path):
    workdir = repository_copy(tmp_path)
    run = subprocess.Popen(["bash", "-c", f"exec {SMOKE_COMMAND}"], cwd=workdir, env=shell_environment(),
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)  # fmt: skip
    try:
        deadline = time.monotonic() + 600
        while not _training_in_progress(workdir) and run.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
    finally:
        os.killpg(run.pid, signal.SIGKILL)  # Snakemake and its jobs, as a crash would
        run.wait()
    interrupted = _marked_incomplete(workdir)
    assert any("/models/" in path for path in interrupted), interrupted
    for path in interrupted:  # the worst case: the killed jobs had begun to write their outputs
        (workdir / path).parent.mkdir(parents=True, exist_ok=True)
        (workdir / path).write_bytes(b"half written")

    refused = run_command(workdir, SMOKE_COMMAND)  # the half-written outputs are not taken as results
    assert refused.returncode != 0 and "--rerun-incomplete" in refused.stderr
    locked = run_command(workdir, on_smoke(RESUME))  # nor is the dead run's lock ignored
    assert locked.returncode != 0 and "--unlock" in locked.stderr
    assert run_command(workdir, on_smoke(UNLOCK)).returncode == 0

    resumed = run_command(workdir, on_smoke(RESUME))
    assert resumed.returncode == 0, f"{resumed.stdout[-3000:]}\n{resumed.stderr[-6000:]}"
    assert _marked_incomplete(workdir) == []
    assert result_hashes(workdir) == result_hashes(smoke_run)
