"""Shared fixtures: configs, small simulated data sets, and one smoke run of the workflow."""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from costa.config import load_config
from costa.physics import ablated_model, true_model
from costa.simulate import SimulationSettings

REPOSITORY = Path(__file__).resolve().parents[1]

#: The README's command for the tiny config, run as written in a copy of the repository.
SMOKE_COMMAND = "snakemake --cores 2 --configfile config/smoke.yaml"
SMOKE_CONFIG = "config/smoke.yaml"


def on_smoke(command: str) -> str:
    """A README command of the default config as the tests run it: on the smoke config, whose results
    go under results/smoke/ (the smoke config first, so that a config the command names overrides it)."""
    command = command.replace(" results/", " results/smoke/")
    if "--configfile " in command:
        return command.replace("--configfile ", f"--configfile {SMOKE_CONFIG} ", 1)
    return f"{command} --configfile {SMOKE_CONFIG}"


#: Wall-clock seconds of the runs the tests start, by name (the SLURM test reports them side by side).
TIMINGS: dict[str, float] = {}


@pytest.fixture(scope="session")
def default_config() -> dict:
    return load_config(REPOSITORY / "config" / "config.yaml")


@pytest.fixture(scope="session")
def settings(default_config) -> SimulationSettings:
    return SimulationSettings.from_config(default_config["simulation"])


@pytest.fixture(scope="session")
def model():
    return true_model()


@pytest.fixture(scope="session")
def pbm():
    return ablated_model()


@pytest.fixture()
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def smoke_config() -> dict:
    return load_config(REPOSITORY / "config" / "config.yaml", REPOSITORY / "config" / "smoke.yaml")


@pytest.fixture(scope="session")
def smoke_train(smoke_config) -> tuple[np.ndarray, np.ndarray]:
    """States (3, 400, 8) and inputs (3, 400, 5) of the smoke config's training set."""
    from costa.data import arrays
    from costa.datasets import simulate_split

    table, _ = simulate_split(smoke_config, "train", replicate=0)
    return arrays(table)


def repository_copy(destination: Path) -> Path:
    """The repository as a fresh clone has it (tracked files and new ones git does not ignore), in ``destination``."""
    listed = subprocess.run(
        ["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=REPOSITORY, capture_output=True
    )  # fmt: skip
    if listed.returncode != 0:  # not a git checkout: everything but generated and environment folders
        ignore = shutil.ignore_patterns(
            ".git", ".venv", ".snakemake", ".pytest_cache", "results", "__pycache__", "*.egg-info"
        )
        shutil.copytree(REPOSITORY, destination, ignore=ignore, dirs_exist_ok=True)
        return destination
    for name in filter(None, listed.stdout.decode().split("\0")):
        source, target = REPOSITORY / name, destination / name
        if source.is_file():
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target)
    return destination


def shell_environment(base: dict[str, str] | None = None) -> dict[str, str]:
    """``base`` (this process's environment) as after activating this Python's virtual environment."""
    base = dict(os.environ if base is None else base)
    return {**base, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{base.get('PATH', '')}"}


def run_command(
    workdir: Path, command: str, env: dict[str, str] | None = None, timeout: float | None = None
) -> subprocess.CompletedProcess:
    """A shell command line run as written in ``workdir`` (a copy of the repository)."""
    return subprocess.run(
        ["bash", "-c", command], cwd=workdir, env=shell_environment(env), capture_output=True, text=True,
        timeout=timeout,
    )  # fmt: skip


def snakemake(workdir: Path, *args: str, check: bool = True, env: dict | None = None) -> subprocess.CompletedProcess:
    """Snakemake with 2 cores in ``workdir``: the workflow there (a repository copy), else this repository's."""
    where = (
        []
        if (workdir / "Snakefile").exists()
        else ["--snakefile", str(REPOSITORY / "Snakefile"), "--directory", str(workdir)]
    )
    result = subprocess.run(
        [sys.executable, "-m", "snakemake", *where, "--cores", "2", *args],
        capture_output=True, text=True, cwd=workdir, env=env,
    )  # fmt: skip
    if check and result.returncode != 0:
        raise AssertionError(f"snakemake {args} failed:\n{result.stdout[-3000:]}\n{result.stderr[-6000:]}")
    return result


def file_hashes(folder: Path) -> dict[str, str]:
    """relative path -> sha256 of every file under ``folder``."""
    return {
        str(path.relative_to(folder)): hashlib.sha256(path.read_bytes()).hexdigest()
        for path in sorted(folder.rglob("*"))
        if path.is_file()
    }


#: What two runs of the same config must agree on byte for byte: data, models, metrics and findings.
RESULT_FOLDERS = ("data", "models", "eval", "discovery", "line")
RESULT_SUFFIXES = (".parquet", ".csv", ".json", ".pt")
#: The recorded values that differ between two runs: how long discovery and a pot's screen took.
TIMING_FIELDS = ("discovery_seconds", "seconds")


def result_hashes(workdir: Path, results: str = "results/smoke") -> dict[str, str]:
    """sha256 of every data, model, metric and finding file of a run, with the recorded run times left out."""
    import io
    import json

    import pandas as pd

    hashes = {}
    root = workdir / results
    for path in sorted(root.rglob("*")):
        name = str(path.relative_to(root))
        if not (path.is_file() and name.split("/")[0] in RESULT_FOLDERS and name.endswith(RESULT_SUFFIXES)):
            continue
        content = path.read_bytes()
        if path.suffix == ".json":
            record = json.loads(content)
            if isinstance(record, dict):
                record = {k: v for k, v in record.items() if k not in TIMING_FIELDS}
            content = json.dumps(record, sort_keys=True).encode()
        elif path.suffix == ".csv":
            table = pd.read_csv(io.BytesIO(content))
            content = table.drop(columns=[c for c in TIMING_FIELDS if c in table]).to_csv(index=False).encode()
        hashes[name] = hashlib.sha256(content).hexdigest()
    return hashes


@pytest.fixture(scope="session")
def smoke_run(tmp_path_factory) -> Path:
    """A copy of the repository in which the README's smoke command has run (results under results/smoke/).

    With ``COSTA_TEST_SMOKE_CACHE`` set (CI sets it), a run made from the same files by an earlier
    session (the fast tier, then the integration tier) is copied from that folder, with its times,
    instead of run again."""
    workdir = repository_copy(tmp_path_factory.mktemp("smoke"))
    cache = os.environ.get("COSTA_TEST_SMOKE_CACHE")
    tree = hashlib.sha256(repr(sorted(file_hashes(workdir).items())).encode()).hexdigest()
    kept = Path(cache) / tree if cache else None
    if kept is not None and (kept / "seconds").is_file():
        shutil.copytree(kept / "run", workdir, symlinks=True, dirs_exist_ok=True)
        TIMINGS["local smoke run"] = float((kept / "seconds").read_text())
        return workdir
    started = time.perf_counter()
    result = run_command(workdir, SMOKE_COMMAND)
    TIMINGS["local smoke run"] = time.perf_counter() - started
    assert result.returncode == 0, f"{SMOKE_COMMAND} failed:\n{result.stdout[-3000:]}\n{result.stderr[-6000:]}"
    if kept is not None:
        shutil.copytree(workdir, kept / "run", symlinks=True, dirs_exist_ok=True)
        (kept / "seconds").write_text(str(TIMINGS["local smoke run"]))
    return workdir


#: A small simulated line: four pots of 60 h on a pot line's sensors, two tapped short (results under results/tinyline/).
TINY_LINE_CONFIG = """\
output: {results: results/tinyline, report: results/tinyline/report}
discovery:
  sensor_sets:
    short_line: {operation: pot_line, hours: 60, gap_restart_hours: 24,
      channels: {U_pot: {every_s: 10, noise: 0.005}, x6: {every_s: 28800, noise: 1.5},
                 c3: {every_s: 28800, noise: 0.002}, x5: {every_s: 28800, noise: 15}}}
line: {name: tiny, simulated: {pots: 4, sensors: short_line, groups: [{case: tapping_shortfall, pots: [1, 2]}]}}
"""
#: The tiny line's page, the target of every file of the line
TINY_LINE_TARGET = "results/tinyline/line/tiny/line.md"


@pytest.fixture(scope="session")
def tiny_line_run(tmp_path_factory) -> Path:
    """A copy of the repository in which the tiny line (:data:`TINY_LINE_CONFIG`, ``tinyline.yaml``) has
    run on 2 cores: screened, grouped, each group searched and checked, the page written."""
    workdir = repository_copy(tmp_path_factory.mktemp("tinyline"))
    (workdir / "tinyline.yaml").write_text(TINY_LINE_CONFIG)
    started = time.perf_counter()
    result = snakemake(workdir, TINY_LINE_TARGET, "--configfile", "tinyline.yaml", check=False)
    TIMINGS["local tiny line"] = time.perf_counter() - started
    assert result.returncode == 0, result.stderr[-4000:]
    return workdir
