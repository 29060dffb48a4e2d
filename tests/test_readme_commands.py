"""Every command the README shows is run by a test as written, so that a command that drifts fails CI.

Commands of the default config run on the smoke config instead (:func:`conftest.on_smoke`:
the same words plus ``--configfile config/smoke.yaml``, results under results/smoke/).
How each is covered:

- the set-up lines: CI's script ``.ci/run`` runs the test line exactly (checked here);
  the other line is the same set-up followed by the default run;
- the smoke run is the ``smoke_run`` fixture (conftest); the discovery target runs here
  in its folder (built by it, nothing left to do); the discovery on your own data runs in
  a fresh copy with a CSV made from simulated smoke data; Snakemake's report runs here; the five-replicate config runs here as a dry run (tests/test_workflow.py
  runs two replicates end to end), and so do the sensor sets; the worked own-cell example
  (its own small config) runs in tests/test_own_data.py; the cell-constants table runs here;
  the peers stage and the beyond config run here as dry runs (tests/test_workflow.py runs its DAG at smoke size),
  and the bound variants on the smoke run's trained models;
- the commands after a crash run in tests/test_resume.py, the cluster command in
  tests/test_slurm.py;
- the training benchmark runs here with 2 timed batches per variant (as written under
  ``-m slow``); ``pytest -m slow`` is collected here (it is the slow suite itself); the conda
  command runs as a dry run where conda is installed.
"""

from __future__ import annotations

import re
import shutil

import pandas as pd
import pytest
import yaml
from conftest import REPOSITORY, SMOKE_COMMAND, on_smoke, repository_copy, run_command

README = (REPOSITORY / "README.md").read_text()
PROGRAMS = ("snakemake", "python", "python3", "pytest", "pip")


def readme_commands() -> set[str]:
    """Command lines in the README's bash blocks and inline code spans that start with a program."""
    blocks = re.findall(r"```bash\n(.*?)```", README, re.S)
    commands = {line.strip() for block in blocks for line in block.splitlines() if line.strip()[:1] not in ("", "#")}
    prose = re.sub(r"```.*?```", "", README, flags=re.S)
    commands |= {span for span in re.findall(r"`([^`\n]+)`", prose) if span.split()[0] in PROGRAMS}
    return commands


def _ci_line() -> str:
    lines = [line for line in (REPOSITORY / ".ci/run").read_text().splitlines() if line.startswith("python3 -m venv")]
    assert len(lines) == 1, lines
    return lines[0]


def check_ci_runs_it(command, smoke_run, tmp_path):
    assert command == _ci_line()


def check_setup_then_default_run(command, smoke_run, tmp_path):
    setup, run = command.rsplit(" && ", 1)
    assert setup == _ci_line().rsplit(" && ", 1)[0].replace("pip install -q ", "pip install ")
    assert on_smoke(run) == SMOKE_COMMAND and (smoke_run / "results/smoke/report/report.html").is_file()


def check_smoke_run(command, smoke_run, tmp_path):
    assert on_smoke(command) == SMOKE_COMMAND or command == SMOKE_COMMAND
    assert (smoke_run / "results/smoke/report/report.html").is_file()


def check_target_is_built(command, smoke_run, tmp_path):
    """The command in the smoke run's folder: its target is a target of the workflow, built and up to date."""
    result = run_command(smoke_run, on_smoke(command))
    assert result.returncode == 0, result.stderr[-4000:]
    assert (
        "Nothing to be done" in result.stdout + result.stderr
        and (smoke_run / on_smoke(command).split()[-3]).stat().st_size > 0
    )


def check_report(command, smoke_run, tmp_path):
    smoke = on_smoke(command)
    target = smoke_run / smoke.split("--report ")[1].split()[0]
    result = run_command(smoke_run, smoke)
    assert result.returncode == 0, result.stderr[-4000:]
    assert target.stat().st_size > 100_000


def check_replicates_dry_run(command, smoke_run, tmp_path):
    result = run_command(smoke_run, f"{on_smoke(command)} --dry-run")
    assert result.returncode == 0, result.stderr[-4000:]
    assert "aggregate_replicates" in result.stdout and "results/smoke/replicates/r4/" in result.stdout


def check_own_data(command, smoke_run, tmp_path):
    """The README's config line, in a fresh copy, with a CSV of simulated smoke-size measurements where it
    says data/cell.csv (the smoke run's training set)."""
    workdir = repository_copy(tmp_path / "repository")
    user_data = yaml.safe_load(re.search(r"`discovery\.user_data: (\{[^`]*\})`", README).group(1))
    measured = pd.read_parquet(smoke_run / "results/smoke/data/train.parquet").drop(columns=["g1", "U_cell"])
    (workdir / user_data["path"]).parent.mkdir(parents=True, exist_ok=True)
    measured.to_csv(workdir / user_data["path"], index=False)
    config_name = command.split("--configfile ")[1].split()[0]
    (workdir / config_name).write_text(yaml.safe_dump({"discovery": {"user_data": user_data}}))
    result = run_command(workdir, on_smoke(command))
    assert result.returncode == 0, result.stderr[-4000:]
    findings = workdir / f"results/smoke/discovery/{user_data['name']}/findings.json"
    assert findings.stat().st_size > 0


def check_sensors_dry_run(command, smoke_run, tmp_path):
    result = run_command(smoke_run, f"{on_smoke(command)} --dry-run")
    assert result.returncode == 0, result.stderr[-4000:]
    assert "collect_sensors" in result.stdout and "results/smoke/discovery/sensors.csv" in result.stdout


def check_beyond_dry_run(command, smoke_run, tmp_path):
    result = run_command(smoke_run, f"{on_smoke(command)} --dry-run")
    assert result.returncode == 0, result.stderr[-4000:]
    assert "rollout_discovered" in result.stdout and "results/smoke/beyond/" in result.stdout


def check_peers_dry_run(command, smoke_run, tmp_path):
    result = run_command(smoke_run, f"{on_smoke(command)} --dry-run")
    assert result.returncode == 0, result.stderr[-4000:]
    assert "collect_peers" in result.stdout and "results/smoke/peers/summary.csv" in result.stdout


def check_bound_variants(command, smoke_run, tmp_path):
    """On the smoke run's trained models (its only replicate stands in for replicate 1)."""
    smoke = command.replace('--reps "" replicates/r1/', '--reps ""')
    config = f"{REPOSITORY / 'config/config.yaml'} {REPOSITORY / 'config/smoke.yaml'}"
    result = run_command(smoke_run, f"{smoke} --results results/smoke --config {config}", timeout=600)
    assert result.returncode == 0, result.stderr[-4000:]


def check_worked_example(command, smoke_run, tmp_path):
    """The example's own small config (not the smoke one) runs in tests/test_own_data.py."""
    assert command in (REPOSITORY / "tests/test_own_data.py").read_text()


def check_cell_constants(command, smoke_run, tmp_path):
    workdir = tmp_path
    (workdir / command.split()[-1]).write_text("physics: {cell: {ledge_area: 21.5}}\n")
    result = run_command(workdir, command)
    assert result.returncode == 0, result.stderr[-4000:]
    assert re.search(r"\bk9 +2\.15", result.stdout), result.stdout[:2000]  # the area the config set


def check_benchmark(command, smoke_run, tmp_path):
    result = run_command(smoke_run, f"{command} --batches 2", timeout=600)
    assert result.returncode == 0, result.stderr[-4000:]


def check_slow_suite_is_collected(command, smoke_run, tmp_path):
    result = run_command(REPOSITORY, f"{command} --collect-only -q -p no:cacheprovider")
    assert result.returncode == 0 and re.search(r"\d+/\d+ tests collected", result.stdout), result.stdout[-2000:]


def check_conda_dry_run(command, smoke_run, tmp_path):
    if shutil.which("conda") is None and shutil.which("mamba") is None:
        pytest.skip("conda is not installed (the conda command needs it)")
    result = run_command(smoke_run, f"{on_smoke(command)} --dry-run")
    assert result.returncode == 0, result.stderr[-4000:]


def check_resume(command, smoke_run, tmp_path):
    from test_resume import RESUME, UNLOCK

    assert command in (UNLOCK, RESUME)  # run by tests/test_resume.py on the smoke config


def check_cluster(command, smoke_run, tmp_path):
    from test_slurm import CLUSTER_COMMAND

    assert on_smoke(command) == CLUSTER_COMMAND  # run by tests/test_slurm.py


#: Every README command and the check that runs it.
CHECKS = {
    "python3 -m venv .venv && . .venv/bin/activate && pip install -r envs/requirements.txt -e . && snakemake --cores 2":
        check_setup_then_default_run,
    "python3 -m venv .venv && . .venv/bin/activate && pip install -q -r envs/requirements.txt -e . && pytest":
        check_ci_runs_it,
    "snakemake --cores 2": check_smoke_run,
    "snakemake --cores 2 --configfile config/smoke.yaml": check_smoke_run,
    "snakemake --cores 2 --configfile config/replicates.yaml": check_replicates_dry_run,
    "snakemake --cores 2 results/discovery/summary.csv": check_target_is_built,
    "snakemake --cores 2 results/discovery/cell/findings.json --configfile my.yaml": check_own_data,
    "snakemake --cores 2 results/own-cell/discovery/cell/findings.json --configfile examples/own-cell/config.yaml":
        check_worked_example,
    "python -m costa.cell_constants my.yaml": check_cell_constants,
    "snakemake --cores 2 results/discovery/sensors.csv --configfile config/sensors.yaml": check_sensors_dry_run,
    "snakemake --cores 2 --configfile config/beyond.yaml": check_beyond_dry_run,
    "snakemake --cores 2 results/peers/summary.csv": check_peers_dry_run,
    "python benchmarks/bound_variants.py": check_bound_variants,
    'python benchmarks/bound_variants.py --reps "" replicates/r1/': check_bound_variants,
    "snakemake --report results/snakemake_report.html": check_report,
    "python benchmarks/train_speed.py": check_benchmark,
    "pytest -m slow": check_slow_suite_is_collected,
    "snakemake --cores 2 --software-deployment-method conda": check_conda_dry_run,
    "snakemake --cores 2 --unlock": check_resume,
    "snakemake --cores 2 --rerun-incomplete": check_resume,
    "snakemake --workflow-profile workflow/profiles/slurm": check_cluster,
}  # fmt: skip


def test_every_readme_command_has_a_check():
    assert readme_commands() == set(CHECKS)


@pytest.mark.parametrize("command", CHECKS)
def test_readme_command(command, smoke_run, tmp_path):
    CHECKS[command](command, smoke_run, tmp_path)


@pytest.mark.slow
def test_training_benchmark_as_written(smoke_run):
    result = run_command(smoke_run, "python benchmarks/train_speed.py", timeout=1800)
    assert result.returncode == 0, result.stderr[-4000:]
