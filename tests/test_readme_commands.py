"""Every command and config block the user documents show is checked as written, so that a command that drifts
fails CI; and the documents stay a guide: short, without copied passages, every page reachable from the README.

The documents: README.md, docs/own-data.md, docs/discovery.md and docs/results.md. Their ```bash lines and the
inline code spans that start with a program are their commands; their ```yaml blocks are configs; their
```python blocks are run.

Fast (the default suite, seconds): every command has a check; every config block is a valid config merged over
config/config.yaml; each config template with ``discovery.user_data`` is followed by the command that runs it,
whose target is ``<output.results>/discovery/<name>/findings.json``, and that command runs as a dry run with the
template saved under the name it gives and a table of the shape the template describes; the Python blocks run;
the commands whose whole run is tested elsewhere are the ones that test runs. Integration (``-m integration``):
the commands that run on the smoke config (:func:`conftest.on_smoke`: the same words plus ``--configfile
config/smoke.yaml``, results under results/smoke/), in the ``smoke_run`` fixture's folder:

- the set-up lines: CI's script ``.ci/run`` runs the test line exactly (checked here); the other line is the same
  set-up followed by the default run;
- the discovery target runs in the smoke run's folder (built by it, nothing left to do); the dense own-data
  template runs in a fresh copy on a CSV made from simulated smoke data; Snakemake's report runs; the
  five-replicate config, the sensor sets, the peers stage and the beyond config run as dry runs
  (tests/test_workflow.py runs their DAGs at smoke size); the bound variants run on the smoke run's trained
  models; the worked own-cell example (its own small config) runs in tests/test_own_data.py;
- the commands after a crash run in tests/test_resume.py, the cluster command in tests/test_slurm.py;
- the training benchmark runs with 2 timed batches per variant (as written under ``-m slow``); ``pytest -m slow``
  and ``pytest -m integration`` are collected (they are those suites themselves); the conda command runs as a
  dry run where conda is installed.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from conftest import REPOSITORY, SMOKE_COMMAND, SMOKE_CONFIG, on_smoke, repository_copy, run_command, snakemake

#: The documents whose commands and config blocks are checked as written.
DOCUMENTS = ("README.md", "docs/own-data.md", "docs/discovery.md", "docs/results.md")
PROGRAMS = ("snakemake", "python", "python3", "pytest", "pip")
EXAMPLE_CSV = REPOSITORY / "examples/own-cell/cell.csv"


def _text(document: str) -> str:
    return (REPOSITORY / document).read_text()


def blocks(document: str, language: str) -> list[tuple[int, str]]:
    """The ```language blocks of a document: (offset in the text, content)."""
    return [(m.start(), m.group(1)) for m in re.finditer(rf"```{language}\n(.*?)```", _text(document), re.S)]


def _command_lines(block: str) -> list[str]:
    """A bash block's command lines, without comment lines and trailing comments."""
    lines = (re.sub(r"\s+#\s.*$", "", line).strip() for line in block.splitlines())
    return [line for line in lines if line and not line.startswith("#")]


def doc_commands(document: str) -> set[str]:
    """Command lines in a document's bash blocks and inline code spans that start with a program."""
    commands = {line for _, block in blocks(document, "bash") for line in _command_lines(block)}
    prose = re.sub(r"```.*?```", "", _text(document), flags=re.S)
    commands |= {span for span in re.findall(r"`([^`\n]+)`", prose) if span.split()[0] in PROGRAMS}
    return commands


def all_commands() -> set[str]:
    return set().union(*(doc_commands(document) for document in DOCUMENTS))


# --- config templates -------------------------------------------------------------------------------------


def templates() -> list[tuple[str, dict, str]]:
    """(document, config, command) for each yaml block that sets ``discovery.user_data``, with the first
    snakemake command of the next bash block: the command that runs it."""
    found = []
    for document in DOCUMENTS:
        bash = blocks(document, "bash")
        for offset, block in blocks(document, "yaml"):
            config = yaml.safe_load(block)
            if not (config.get("discovery") or {}).get("user_data"):
                continue
            following = [b for o, b in bash if o > offset]
            commands = [c for c in _command_lines(following[0]) if c.startswith("snakemake")] if following else []
            found.append((document, config, commands[0] if commands else ""))
    return found


def _template_id(template) -> str:
    return f"{template[0]}:{template[1]['discovery']['user_data']['name']}"


def template_table(config: dict) -> pd.DataFrame:
    """A trajectory table of the shape a template describes: the worked example's cell (6 trajectories x 400
    steps); every state at every step where the template declares no sensor noise, else the pot voltage at
    every step and the declared channels every 50 steps, empty in between."""
    table = pd.read_csv(EXAMPLE_CSV)
    noise = config["discovery"]["user_data"].get("noise") or {}
    if not noise:
        return table
    from costa.data import arrays
    from costa.observe import observe
    from costa.physics import true_model

    x, u = arrays(table)
    channels = ["U_pot", *noise]
    values = observe(true_model(), x, u, channels).reshape(-1, len(channels))
    measured = table[["trajectory", "time_s", "u1", "u2", "u3", "u4", "u5"]].copy()
    sampled = table.groupby("trajectory").cumcount().to_numpy() % 50 == 0
    for c, name in enumerate(channels):
        measured[name] = values[:, c] if name == "U_pot" else np.where(sampled, values[:, c], np.nan)
    return measured


def template_events(table: pd.DataFrame) -> pd.DataFrame:
    """An events table for a template's record: in every trajectory an alumina dose, an AlF3 addition and a tap."""
    rows = [(t, time, kind, amount, duration) for t in table["trajectory"].unique()
            for time, kind, amount, duration in ((300.0, "alumina_dose", 1.8, 0.0), (600.0, "alf3_addition", 20.0, 0.0),
                                                 (1200.0, "tap", 1000.0, 600.0))]  # fmt: skip
    return pd.DataFrame(rows, columns=["trajectory", "time_s", "kind", "amount_kg", "duration_s"])


def snakemake_as_written(workdir: Path, command: str, *extra: str) -> subprocess.CompletedProcess:
    """A document's snakemake command as written, in ``workdir`` (which holds its config and data, not the
    workflow), with this repository's Snakefile."""
    words = command.split()
    assert words[0] == "snakemake", command
    return subprocess.run(
        [sys.executable, "-m", "snakemake", "--snakefile", str(REPOSITORY / "Snakefile"), *words[1:], *extra],
        cwd=workdir, capture_output=True, text=True, timeout=300,
    )  # fmt: skip


# --- fast checks: the commands a test runs elsewhere, or that the template test runs --------------------------


def _ci_line() -> str:
    lines = [line for line in (REPOSITORY / ".ci/run").read_text().splitlines() if line.startswith("python3 -m venv")]
    assert len(lines) == 1, lines
    return lines[0]


def check_ci_runs_it(command, tmp_path):
    assert command == _ci_line()


def check_worked_example(command, tmp_path):
    """The example's own small config (not the smoke one) runs in tests/test_own_data.py."""
    assert command in (REPOSITORY / "tests/test_own_data.py").read_text()


def check_pot_line_example(command, tmp_path):
    """Run end to end, after the example's make_export.py, by tests/test_historian.py (integration tier)."""
    source = (REPOSITORY / "tests/test_historian.py").read_text()
    target, config = command.removeprefix("snakemake --cores 2 ").split(" --configfile ")
    assert f'target = "{target}"' in source and f"--configfile {config}" in source


def check_line_dry_run(command, tmp_path):
    """A simulated line of 24 pots: its DAG up to its checkpoint (its pots simulated and screened, then
    grouped); the whole line runs small in tests/test_line.py (integration tier)."""
    target, config = command.removeprefix("snakemake --cores 2 ").split(" --configfile ")
    (tmp_path / config).parent.mkdir(parents=True)
    shutil.copy(REPOSITORY / config, tmp_path / config)
    result = snakemake(tmp_path, target, "--configfile", config, "--dry-run", check=False)
    assert result.returncode == 0, result.stderr[-4000:]
    assert re.search(r"line_screen\s+24", result.stdout) and "line_groups" in result.stdout, result.stdout[-2000:]


def check_template_dry_run(command, tmp_path):
    """Run by test_config_templates_run_as_written (a dry run with the template and a table of its shape)."""
    assert command in [t[2] for t in templates()]


def check_historian_import(command, tmp_path):
    """The historian block of docs/own-data.md as written, in a fresh copy, with test_historian's small
    export, lab samples and events where the block says: the import runs and writes the contract's tables."""
    from test_historian import EVENTS, LAB, TAGS, _export, _good_rows

    [block] = [b for document in DOCUMENTS for _, b in blocks(document, "yaml") if b.startswith("historian:")]
    historian = yaml.safe_load(block)["historian"]
    workdir = repository_copy(tmp_path / "repository")
    texts = {"export": _export(_good_rows()), "tags": TAGS, "lab": LAB, "events": EVENTS}
    for key, text in texts.items():
        (workdir / historian[key]).parent.mkdir(parents=True, exist_ok=True)
        (workdir / historian[key]).write_text(text)
    (workdir / command.split("--configfile ")[1].split()[0]).write_text(block)
    result = run_command(workdir, command)
    assert result.returncode == 0, result.stderr[-4000:]
    folder = workdir / command.split()[3].rsplit("/", 1)[0]
    assert (folder / "record.parquet").stat().st_size > 0 and "Anode effects" in (folder / "import.md").read_text()


def check_cell_constants(command, tmp_path):
    (tmp_path / command.split()[-1]).write_text("physics: {cell: {ledge_area: 21.5}}\n")
    result = run_command(tmp_path, command)
    assert result.returncode == 0, result.stderr[-4000:]
    assert re.search(r"\bk9 +2\.15", result.stdout), result.stdout[:2000]  # the area the config set


def check_resume(command, tmp_path):
    from test_resume import RESUME, UNLOCK

    assert command in (UNLOCK, RESUME)  # run by tests/test_resume.py on the smoke config


def check_cluster(command, tmp_path):
    from test_slurm import CLUSTER_COMMAND

    assert on_smoke(command) == CLUSTER_COMMAND  # run by tests/test_slurm.py


# --- integration checks: on the smoke run ------------------------------------------------------------------


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


def check_own_data_template(command, smoke_run, tmp_path):
    """The dense template of docs/own-data.md as written, in a fresh copy, at the smoke config's discovery
    settings (the smoke config before the template, which wins), on a CSV of simulated smoke-size measurements
    where the template says (the smoke run's training set)."""
    [(_, config, _)] = [t for t in templates() if t[2] == command]
    workdir = repository_copy(tmp_path / "repository")
    user_data = config["discovery"]["user_data"]
    measured = pd.read_parquet(smoke_run / "results/smoke/data/train.parquet").drop(columns=["g1", "U_cell"])
    (workdir / user_data["path"]).parent.mkdir(parents=True, exist_ok=True)
    measured.to_csv(workdir / user_data["path"], index=False)
    config_name = command.split("--configfile ")[1].split()[0]
    (workdir / config_name).write_text(yaml.safe_dump(config))
    result = run_command(workdir, command.replace("--configfile ", f"--configfile {SMOKE_CONFIG} "))
    assert result.returncode == 0, result.stderr[-4000:]
    assert (workdir / command.split()[3]).stat().st_size > 0


def check_sensors_dry_run(command, smoke_run, tmp_path):
    result = run_command(smoke_run, f"{on_smoke(command)} --dry-run")
    assert result.returncode == 0, result.stderr[-4000:]
    assert "collect_sensors" in result.stdout and "results/smoke/discovery/sensors.csv" in result.stdout
    # a sparse set's first round as a screen and discovery.search_jobs (4) fit jobs; the full set in one job
    assert "discovery/no_effect/sensors/plant/search/fit_3_of_4.pkl" in result.stdout
    assert "discovery/no_effect/sensors/full/search" not in result.stdout


def check_nine_cases_dry_run(command, smoke_run, tmp_path):
    result = run_command(smoke_run, f"{on_smoke(command)} --dry-run")
    assert result.returncode == 0, result.stderr[-4000:]
    for case in ("top_heat_loss", "tapping_shortfall", "no_effect"):
        assert f"results/smoke/discovery/{case}/findings.json" in result.stdout, case


def check_beyond_dry_run(command, smoke_run, tmp_path):
    result = run_command(smoke_run, f"{on_smoke(command)} --dry-run")
    assert result.returncode == 0, result.stderr[-4000:]
    assert "rollout_discovered" in result.stdout and "results/smoke/beyond/" in result.stdout


def check_peers_dry_run(command, smoke_run, tmp_path):
    result = run_command(smoke_run, f"{on_smoke(command)} --dry-run")
    assert result.returncode == 0, result.stderr[-4000:]
    assert "collect_peers" in result.stdout and "results/smoke/peers/summary.csv" in result.stdout


def check_benchmark_dry_run(command, smoke_run, tmp_path):
    """The quick size on the test seeds: each set's first drawn cases, their signals, one table."""
    result = run_command(smoke_run, f"{on_smoke(command)} --dry-run")
    assert result.returncode == 0, result.stderr[-4000:]
    assert (
        "collect_benchmark" in result.stdout
        and "results/smoke/benchmark/signal/pot_line/drawn100003.json" in result.stdout
    )
    assert "results/smoke/discovery/drawn100023/findings.json" in result.stdout
    assert "discovery/drawn100008/sensors/partial" not in result.stdout  # partial's 8 cases are the first 8


def check_bound_variants(command, smoke_run, tmp_path):
    """On the smoke run's trained models (its only replicate stands in for replicate 1)."""
    smoke = command.replace('--reps "" replicates/r1/', '--reps ""')
    config = f"{REPOSITORY / 'config/config.yaml'} {REPOSITORY / 'config/smoke.yaml'}"
    result = run_command(smoke_run, f"{smoke} --results results/smoke --config {config}", timeout=600)
    assert result.returncode == 0, result.stderr[-4000:]


def check_benchmark(command, smoke_run, tmp_path):
    result = run_command(smoke_run, f"{command} --batches 2", timeout=600)
    assert result.returncode == 0, result.stderr[-4000:]


def check_shooting_benchmark(command, smoke_run, tmp_path):
    result = run_command(
        smoke_run, f"{command} --cases tapping_shortfall --cells 1 --hours 1 --iterations 1 1", timeout=600
    )
    assert result.returncode == 0, result.stderr[-4000:]
    assert all(key in result.stdout for key in ("input:u4", "property:current_efficiency", "cost")), result.stdout


def check_form_screen_benchmark(command, smoke_run, tmp_path):
    result = run_command(
        smoke_run,
        f"{command} --cases tapping_shortfall --cells 1 --hours 18 --refine 1 --iterations 1 1 "
        "--hypotheses property:current_efficiency part:metal_production term:metal_mass",
        timeout=600,
    )
    assert result.returncode == 0, result.stderr[-4000:]
    assert all(key in result.stdout for key in ("screen of 3", "by BIC gain", "verdict:")), result.stdout


def check_compiled_step_benchmark(command, smoke_run, tmp_path):
    """The step's and the tangents' rates at the fits' batch sizes, each beside numpy's in the same process."""
    result = run_command(smoke_run, command, timeout=600)
    assert result.returncode == 0, result.stderr[-4000:]
    rows = re.findall(r"^\s+(96|1152|10000)\s+\S+ M\s+\S+ M\s+\S+x$", result.stdout, re.MULTILINE)
    assert rows == ["96", "1152", "10000"] and "compiled tangents" in result.stdout, result.stdout


def check_closed_loop_dry_run(command, smoke_run, tmp_path):
    """The closed loop over the quick size's sparse cases: each run again with its top recommendation, one page."""
    result = run_command(smoke_run, f"{on_smoke(command)} --dry-run")
    assert result.returncode == 0, result.stderr[-4000:]
    assert "collect_closed_loop" in result.stdout and "discover_next" in result.stdout
    assert "results/smoke/discovery/drawn100003/sensors/pot_line/next/loop.json" in result.stdout
    assert "discovery/drawn100000/sensors/full/next" not in result.stdout  # full-state findings recommend nothing


def check_suite_is_collected(command, smoke_run, tmp_path):
    result = run_command(REPOSITORY, f"{command} --collect-only -q -p no:cacheprovider")
    assert result.returncode == 0 and re.search(r"\d+/\d+ tests collected", result.stdout), result.stdout[-2000:]


def check_conda_dry_run(command, smoke_run, tmp_path):
    if shutil.which("conda") is None and shutil.which("mamba") is None:
        pytest.skip("conda is not installed (the conda command needs it)")
    result = run_command(smoke_run, f"{on_smoke(command)} --dry-run")
    assert result.returncode == 0, result.stderr[-4000:]


#: Document commands whose check is fast (no workflow run), and the check.
FAST_CHECKS = {
    "python3 -m venv .venv && . .venv/bin/activate && pip install -q -r envs/requirements.txt -e . && pytest":
        check_ci_runs_it,
    "snakemake --cores 2 results/own-cell/discovery/cell/findings.json --configfile examples/own-cell/config.yaml":
        check_worked_example,
    "snakemake --cores 2 results/potline/discovery/pot12/findings.json --configfile potline.yaml":
        check_template_dry_run,
    "snakemake --cores 2 results/pot-line/discovery/pot12/findings.json --configfile examples/pot-line/config.yaml":
        check_pot_line_example,
    "python -m costa.cell_constants my.yaml": check_cell_constants,
    "snakemake --cores 2 results/historian/pot12/record.parquet --configfile pot12.yaml": check_historian_import,
    "snakemake --cores 2 results/line/line24/line.md --configfile config/line.yaml": check_line_dry_run,
    "snakemake --cores 2 results/line/tap24/line.md --configfile config/line_tapping.yaml": check_line_dry_run,
    "snakemake --cores 2 --unlock": check_resume,
    "snakemake --cores 2 --rerun-incomplete": check_resume,
    "snakemake --workflow-profile workflow/profiles/slurm": check_cluster,
}  # fmt: skip

#: Document commands checked on the smoke run (``-m integration``), and the check.
RUN_CHECKS = {
    "python3 -m venv .venv && . .venv/bin/activate && pip install -r envs/requirements.txt -e . && snakemake --cores 2":
        check_setup_then_default_run,
    "snakemake --cores 2": check_smoke_run,
    "snakemake --cores 2 --configfile config/smoke.yaml": check_smoke_run,
    "snakemake --cores 2 --configfile config/replicates.yaml": check_replicates_dry_run,
    "snakemake --cores 2 results/discovery/summary.csv": check_target_is_built,
    "snakemake --cores 2 results/mycell/discovery/cell/findings.json --configfile my.yaml": check_own_data_template,
    "snakemake --cores 2 results/discovery/sensors.csv --configfile config/sensors.yaml": check_sensors_dry_run,
    "snakemake --cores 2 results/discovery/summary.csv --configfile config/discovery.yaml": check_nine_cases_dry_run,
    "snakemake --cores 2 --configfile config/beyond.yaml": check_beyond_dry_run,
    "snakemake --cores 2 results/peers/summary.csv": check_peers_dry_run,
    "snakemake --cores 2 results/benchmark/summary.csv --configfile config/benchmark.yaml": check_benchmark_dry_run,
    "snakemake --cores 2 results/benchmark/closed_loop.md --configfile config/benchmark.yaml": check_closed_loop_dry_run,
    'python benchmarks/bound_variants.py --reps "" replicates/r1/': check_bound_variants,
    "snakemake --report results/snakemake_report.html": check_report,
    "python benchmarks/train_speed.py": check_benchmark,
    "python benchmarks/shooting_fits.py": check_shooting_benchmark,
    "python benchmarks/form_screen.py": check_form_screen_benchmark,
    "python benchmarks/compiled_step.py": check_compiled_step_benchmark,
    "pytest -m slow": check_suite_is_collected,
    "pytest -m integration": check_suite_is_collected,
    "snakemake --cores 2 --software-deployment-method conda": check_conda_dry_run,
}  # fmt: skip


def test_every_document_command_has_a_check():
    assert all_commands() == set(FAST_CHECKS) | set(RUN_CHECKS)


@pytest.mark.parametrize("command", FAST_CHECKS)
def test_document_command(command, tmp_path):
    FAST_CHECKS[command](command, tmp_path)


@pytest.mark.integration
@pytest.mark.parametrize("command", RUN_CHECKS)
def test_document_command_on_the_smoke_run(command, smoke_run, tmp_path):
    RUN_CHECKS[command](command, smoke_run, tmp_path)


@pytest.mark.slow
def test_training_benchmark_as_written(smoke_run):
    result = run_command(smoke_run, "python benchmarks/train_speed.py", timeout=1800)
    assert result.returncode == 0, result.stderr[-4000:]


# --- config blocks and Python blocks ------------------------------------------------------------------------


@pytest.mark.parametrize(
    "document, index", [(d, i) for d in DOCUMENTS for i in range(len(blocks(d, "yaml")))], ids=lambda v: str(v)
)
def test_config_blocks_are_valid_configs(document, index):
    """Merged over config/config.yaml, as the workflow merges a config file: the schema and the checks across keys."""
    from costa.config import DEFAULT_CONFIG, load_config

    load_config(DEFAULT_CONFIG, overrides=yaml.safe_load(blocks(document, "yaml")[index][1]))


def test_the_own_data_page_has_a_dense_and_a_sparse_template():
    kinds = {bool(config["discovery"]["user_data"].get("noise")) for document, config, _ in templates()
             if document == "docs/own-data.md"}  # fmt: skip
    assert kinds == {False, True}


@pytest.mark.parametrize("template", templates(), ids=_template_id)
def test_config_templates_run_as_written(template, tmp_path):
    """The command after a template names the template's own target and config file, and runs as a dry run
    with the template saved there and a table of the template's shape at its path (and events, where it names
    an events table); the sensor noise the template declares covers every channel of that table that is not
    sampled at every step."""
    from costa.data import load_trajectories, measured_trajectories
    from costa.discover.sparse.observations import channel_noise

    document, config, command = template
    user_data = config["discovery"]["user_data"]
    results = (config.get("output") or {}).get("results", "results")
    target = f"{results}/discovery/{user_data['name']}/findings.json"
    match = re.fullmatch(r"snakemake --cores 2 (\S+) --configfile (\S+)", command)
    assert match and match.groups()[0] == target, f"{document}: the template's target is {target}: {command!r}"
    (tmp_path / match.groups()[1]).write_text(yaml.safe_dump(config))
    path = tmp_path / user_data["path"]
    path.parent.mkdir(parents=True, exist_ok=True)
    template_table(config).to_csv(path, index=False)
    measured = measured_trajectories(load_trajectories(path))
    channel_noise(measured.values, measured.channels, user_data.get("noise") or {})
    if "events" in user_data:
        template_events(pd.read_csv(path)).to_csv(tmp_path / user_data["events"], index=False)
    result = snakemake_as_written(tmp_path, command, "--dry-run")
    assert result.returncode == 0, result.stdout[-2000:] + result.stderr[-4000:]
    assert "discovery_user_data" in result.stdout, result.stdout[-2000:]
    assert ("discovery_user_events" in result.stdout) == ("events" in user_data), result.stdout[-2000:]


@pytest.mark.parametrize("document", [d for d in DOCUMENTS if blocks(d, "python")])
def test_python_blocks_run(document, tmp_path, monkeypatch):
    """Each Python block, run in a folder where the data file it names is the worked example's table."""
    (tmp_path / "data").mkdir()
    shutil.copy(EXAMPLE_CSV, tmp_path / "data/cell.csv")
    monkeypatch.chdir(tmp_path)
    for _, block in blocks(document, "python"):
        exec(compile(block, document, "exec"), {"__name__": "__doc__"})  # noqa: S102 (the document's own code)


# --- the documents as a whole -------------------------------------------------------------------------------


def _documents() -> list[Path]:
    return [REPOSITORY / "README.md", *sorted((REPOSITORY / "docs").rglob("*.md"))]


def test_no_passage_of_ten_lines_appears_twice():
    """No run of 10 consecutive non-blank lines (blank lines skipped, each line stripped) appears twice,
    within one document or across the README and docs/ (docs/notes/ included): each thing is said once."""
    seen: dict[tuple[str, ...], str] = {}
    repeated = []
    for path in _documents():
        lines = [line.strip() for line in path.read_text().splitlines() if line.strip()]
        name = str(path.relative_to(REPOSITORY))
        for i in range(len(lines) - 9):
            window = tuple(lines[i : i + 10])
            where = f"{name} (non-blank line {i + 1})"
            if window in seen:
                repeated.append(f"{seen[window]} and {where}: {window[0][:80]!r}")
            seen.setdefault(window, where)
    assert not repeated, "\n".join(repeated[:10])


def _links(path: Path) -> set[Path]:
    """The local Markdown files a document links to, resolved from its folder."""
    text = re.sub(r"```.*?```", "", path.read_text(), flags=re.S)
    targets = set()
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        target = target.split("#")[0]
        if target and "://" not in target and target.endswith(".md"):
            targets.add((path.parent / target).resolve())
    return targets


def test_every_document_is_reachable_from_the_readme():
    """Following Markdown links from README.md reaches every docs/*.md and docs/notes/*.md, and every link
    to a local Markdown file resolves."""
    start = (REPOSITORY / "README.md").resolve()
    reached, todo, broken = {start}, [start], []
    while todo:
        path = todo.pop()
        for target in _links(path):
            if not target.is_file():
                broken.append(f"{path.relative_to(REPOSITORY)} -> {target}")
            elif target not in reached:
                reached.add(target)
                todo.append(target)
    assert not broken, broken
    expected = {p.resolve() for p in [*(REPOSITORY / "docs").glob("*.md"), *(REPOSITORY / "docs/notes").glob("*.md")]}
    expected.add((REPOSITORY / "results/README.md").resolve())
    missing = sorted(str(p.relative_to(REPOSITORY)) for p in expected - reached)
    assert not missing, f"not reachable from README.md: {missing}"


def test_the_guides_are_short():
    """A newcomer reads the README and the discovery guide in one sitting."""
    readme = _text("README.md").splitlines()
    guide = _text("docs/discovery.md")
    assert len(readme) <= 200, len(readme)
    assert len(guide.splitlines()) <= 300, len(guide.splitlines())
    limits = guide.split("\n## Limits\n")[1].split("\n## ")[0]
    assert len(limits.strip().splitlines()) <= 40
