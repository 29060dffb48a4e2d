# Paths, wildcards and the library files each stage depends on.
import json
import os
import re
from pathlib import Path

SRC = Path(workflow.basedir) / "src"
PACKAGE = SRC / "costa"
ENV = "../../envs/costa.yaml"

# The scripts import the library from this checkout, whether or not it is installed
# and whichever software deployment runs them.  This provides a variable to the jobs;
# it does not require one from the user.
os.environ.update(
    PYTHONPATH=os.pathsep.join(filter(None, [str(SRC), os.environ.get("PYTHONPATH")]))
)
# One BLAS/OpenMP thread per job unless the job sets more (torch oversubscribes a small machine otherwise).
for _variable in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")
from costa.discover.route import choose_route  # noqa: E402

# The same CPU kernels for every job, whatever the shell says (config `kernels`):
# the numbers then do not depend on the CPU (docs/reproducibility.md).
from costa.kernels import kernel_environment  # noqa: E402
from costa.sensors import declared_noise as sensor_noise  # noqa: E402
from costa.discover.cases.tables import record_settings  # noqa: E402
from costa.line.groups import group_meta  # noqa: E402
from costa.line.pots import Line  # noqa: E402

os.environ.update(kernel_environment(config["kernels"]))


def checkout_file(relative):
    """A file of this checkout as a rule's input, relative to the working directory where it lies
    under it: Snakemake records its inputs' paths, and an absolute one changes when the folder
    moves (a moved or copied run would then redo every stage that reads the library)."""
    path = Path(workflow.basedir) / relative
    return (
        os.path.relpath(path)
        if path.resolve().is_relative_to(Path.cwd().resolve())
        else str(path)
    )


RESULTS = config["output"]["results"]
REPORT = config["output"]["report"]


def out(path):
    """A path under this run's results folder (``output.results``: results/, or results/smoke/ ...)."""
    return f"{RESULTS}/{path}"


MODEL_TYPES = list(config["training"]["model_types"])
# the trained types, the ablated physics model and (config/beyond.yaml) the discovered model
DISCOVERED = ["discovered"] if config["beyond"]["discovered_model"] else []
EVALUATED = [*MODEL_TYPES, "pbm", *DISCOVERED]
REPLICATE_PATTERN = r"(replicates/r[1-9][0-9]*/)?"


wildcard_constraints:
    # a replicate's folder, or (config/beyond.yaml) a noisy-training variant inside it
    rep=REPLICATE_PATTERN + r"(noise/[0-9.]+/)?",
    case=r"[A-Za-z0-9_-]+",
    split="train|test",
    model_type="|".join(MODEL_TYPES),
    model="|".join(EVALUATED),


def replicate_prefix(index):
    """Replicate 0 (the paper's run) is written to the results folder, replicate k to its replicates/rk/."""
    return "" if index == 0 else f"replicates/r{index}/"


def replicate_number(rep):
    """The replicate of a prefix ("" -> 0, "replicates/r3/..." -> 3)."""
    match = re.match(r"replicates/r(\d+)/", rep)
    return int(match.group(1)) if match else 0


def replicate_index(wildcards):
    return replicate_number(wildcards.rep)


def clean_prefix(rep):
    """The replicate's own folder of a (possibly noisy-training) prefix: its test set, its clean training set."""
    return re.sub(r"noise/[0-9.]+/$", "", rep)


REPLICATES = [replicate_prefix(index) for index in range(config["replicates"])]


def across_replicates(*paths):
    """``paths`` when the run has several replicates, else none (one run has nothing to aggregate)."""
    return list(paths) if len(REPLICATES) > 1 else []


def package_files(*modules):
    """Library files whose change must rerun a rule.

    Snakemake reruns a script rule when the script changes, not when the library it
    imports changes; declaring the modules as inputs closes that gap.
    """
    files = []
    for module in modules:
        path = PACKAGE / module
        sources = (p for p in path.rglob("*") if p.suffix in (".py", ".c", ".yaml"))
        found = sorted(sources) if path.is_dir() else [path]
        files += [checkout_file(p.relative_to(workflow.basedir)) for p in found]
    return files


SIMULATION_CODE = package_files(
    "physics",
    "simulate.py",
    "integrate.py",
    "seeds.py",
    "data.py",
    "datasets.py",
    "variables.py",
)

TRAINING_CODE = SIMULATION_CODE + package_files("train.py", "ensemble.py", "models.py")

EVALUATION_CODE = TRAINING_CODE + package_files(
    "forecast.py", "metrics.py", "evaluate.py"
)


def trained_instances(wildcards):
    """The saved instances a rollout needs (none for the PBM)."""
    if wildcards.model == "pbm":
        return []
    return expand(
        out("{rep}models/{model}/instance{i}.pt"),
        rep=wildcards.rep,
        model=wildcards.model,
        i=range(config["training"]["instances"]),
    )


def training_config(model_type):
    """What training one model type depends on, and nothing else (so that changing
    another type's setting, or the test set, retrains nothing)."""
    training = {k: v for k, v in config["training"].items() if k != "model_types"}
    training["model_types"] = {
        model_type: config["training"]["model_types"][model_type]
    }
    return {
        "seed": config["seed"],
        "physics": config["physics"],
        "simulation": {"dt_s": config["simulation"]["dt_s"]},
        "training": training,
    }


DISCOVERY_CODE = SIMULATION_CODE + package_files(
    "discover", "compiled", "observe.py", "forecast.py", "metrics.py"
)
# what a shipped case's data come from: its hidden effect, the simulation and the sensors
# (so that a change of the discovery's own code does not simulate the data again)
CASE_DATA_CODE = SIMULATION_CODE + package_files(
    "discover/cases/shipped.py",
    "discover/cases/shipped.yaml",
    "discover/cases/unshipped.py",
    "discover/cases/tables.py",
    "discover/cases/drawn.py",
    "observe.py",
    "sensors.py",
)
SHIPPED_CASES = list(config["discovery"]["cases"])
USER_CASE = (config["discovery"]["user_data"] or {}).get("name", "")
DISCOVERY_CASES = SHIPPED_CASES + ([USER_CASE] if USER_CASE else [])


def _peer_cases():
    """peers.cases, or every shipped case and every unshipped effect (the registries, read now)."""
    from costa.discover import CASES
    from costa.discover.cases.unshipped import UNSHIPPED

    return list(config["peers"]["cases"] or [*CASES, *UNSHIPPED])


PEER_CASES = _peer_cases()
# the benchmark's drawn cases (costa.discover.cases.drawn): a name, drawn<seed>, says all of one
DRAWN_CASE = r"drawn\d+"
BENCHMARK_SIZE = config["benchmark"]["sizes"][config["benchmark"]["size"]]
BENCHMARK_SETS = BENCHMARK_SIZE["sensors"]


def _benchmark_cases():
    """(case, sensor set) of the configured benchmark: each set's first cases of the split."""
    from costa.discover.cases.drawn import split_cases

    split = config["benchmark"]["split"]
    return [
        (case, sensors)
        for sensors, count in BENCHMARK_SETS.items()
        for case in split_cases(split, count)
    ]


BENCHMARK_CASES = _benchmark_cases()
# the full set's first cases, which the peers also run on
BENCHMARK_PEER_CASES = [case for case, sensors in BENCHMARK_CASES if sensors == "full"][
    : BENCHMARK_SIZE.get("peers", 0)
]
# the cases whose data are simulated: the configured ones and those the peers stage compares on
SIMULATED_CASES = SHIPPED_CASES + [c for c in PEER_CASES if c not in SHIPPED_CASES]
PEERS_CODE = DISCOVERY_CODE + TRAINING_CODE + package_files("peers")


def peers_config(wildcards):
    """What comparing the peers on a case depends on."""
    return {**discovery_config(wildcards), "peers": config["peers"]}


def discovery_config(wildcards):
    """What a discovery run depends on (not the training or the replication's sizes, nor how many
    jobs its search is split into, which changes no finding)."""
    chosen = {
        key: config[key]
        for key in ("seed", "physics", "simulation", "evaluation", "training")
    }
    chosen["discovery"] = {
        k: v for k, v in config["discovery"].items() if k != "search_jobs"
    }
    return chosen


def starting_model_name(wildcards):
    """A shipped case says which model it starts from; your data start from the configured one."""
    if wildcards.case == USER_CASE:
        return config["discovery"]["user_data"]["starting_model"]
    from costa.discover.cases.unshipped import find_case

    return find_case(wildcards.case).starting


def user_measurements(wildcards):
    """Your record as logged, or with the rates of your events added (discovery.user_data.events)."""
    user = config["discovery"]["user_data"]
    if user.get("events"):
        return out(f"discovery/{wildcards.case}/data/measurements.parquet")
    return user["path"]


def simulated_meta(case_name, sensors="full"):
    """What findings.json records about a shipped or unshipped case's simulated data, measured by a
    sensor set, and what is hidden in it."""
    from costa.discover.cases.tables import simulated_data
    from costa.discover.cases.unshipped import find_case

    case = find_case(case_name)
    return {
        "data": simulated_data(config, case_name, sensors),
        "hidden": case.hidden,
        "kind": case.kind,
        "expected_equations": list(case.expected_equations),
        "accepted": list(case.accepted),
    }


def discovery_meta(wildcards):
    """What findings.json records about the data (and, for a shipped case, what is hidden)."""
    if wildcards.case == USER_CASE:
        user = config["discovery"]["user_data"]
        events = f" with the events in {user['events']}" if user.get("events") else ""
        return {
            "data": f"measurements from {user['path']}{events}",
            "unlogged_inputs": user["unlogged_inputs"],
        }
    return simulated_meta(wildcards.case)


SENSOR_SETS = list(config["discovery"]["sensors"])


def sensor_findings(case, sensors):
    """The findings of a shipped case under a sensor set (the full set is the discovery run itself)."""
    if sensors == "full":
        return out(f"discovery/{case}/findings.json")
    return out(f"discovery/{case}/sensors/{sensors}/findings.json")


def sensor_meta(wildcards):
    """What findings.json records about a case measured by a sensor set (a drawn case's own record
    under a set that varies)."""
    sensor_set, _ = record_settings(config, wildcards.sensors, wildcards.case)
    described = ", ".join(
        f"{s.channel} {s.interval}"
        + (f" (noise {s.noise:g})" if s.noise is not None else "")
        for s in sensor_set.sensors
    )
    meta = simulated_meta(wildcards.case, wildcards.sensors)
    return meta | {
        "sensors": wildcards.sensors,
        "data": meta["data"]
        + f", measured by the {wildcards.sensors!r} sensors: {described}",
    }


def declared_noise(wildcards):
    """Noise std of the channels too sparse to estimate it from the data: the sensor set's, or yours."""
    if "sensors" in wildcards.keys():
        return sensor_noise(config["discovery"]["sensor_sets"], wildcards.sensors)
    return dict((config["discovery"]["user_data"] or {}).get("noise", {}))


def job_benchmarks(rep):
    """The benchmark file of every job of one replicate (the report's run-time table)."""
    prefix = out(f"{rep}benchmarks")
    jobs = [f"simulate_{split}" for split in ("train", "test")]
    jobs += [f"train_{model_type}" for model_type in MODEL_TYPES]
    jobs += [f"rollout_{model}" for model in EVALUATED]
    jobs += ["collect_evaluation", "plot_datasets", "plot_training_curves"]
    jobs += ["plot_results", "plot_rolling_forecast"]
    return [f"{prefix}/{job}.tsv" for job in jobs]


def all_targets():
    targets = [f"{REPORT}/report.html", out("results.md"), out("cell_constants.csv")]
    targets += expand(out("discovery/{case}/discovery.png"), case=DISCOVERY_CASES)
    if SENSOR_SETS != ["full"] and SHIPPED_CASES:
        targets.append(out("discovery/sensors.csv"))
    targets += beyond_targets()
    targets += across_replicates(
        out("replicates/aggregate.csv"),
        out("replicates/claims.csv"),
        out("replicates/blowups.png"),
    )
    for rep in REPLICATES:
        prefix = out(rep)
        targets += [
            f"{prefix}data/train.parquet",
            f"{prefix}data/test.parquet",
            f"{prefix}figures/datasets.png",
            f"{prefix}figures/training_curves.png",
            f"{prefix}eval/summary.csv",
            f"{prefix}figures/error_violins.png",
            f"{prefix}figures/rolling_forecast.png",
        ]
    return targets


# Past the paper's forecasts (config/beyond.yaml, workflow/rules/beyond.smk): the noise study.
NOISE = config["beyond"]["noise"]
NOISE_LEVELS = [f"{level:g}" for level in NOISE["levels"]]
NOISE_TYPES = [*NOISE["model_types"], *DISCOVERED]
NOISE_REPLICATES = REPLICATES[: NOISE["replicates"]] if NOISE_LEVELS else []


def noise_prefix(level):
    """Level 0 is the run itself; level p trains on {replicate}noise/p/data/train.parquet."""
    return "" if float(level) == 0 else f"noise/{level}/"


# every noise study rollout, in one order: (replicate, level, model) and its metrics file
NOISE_RUNS = [
    (
        replicate_number(rep),
        float(level),
        model,
        out(f"{rep}{noise_prefix(level)}eval/{model}/metrics.parquet"),
    )
    for rep in NOISE_REPLICATES
    for level in NOISE_LEVELS
    for model in NOISE_TYPES
]


def beyond_targets():
    return [out("beyond/noise.csv"), out("beyond/noise.png")] if NOISE_RUNS else []


def split_search(wildcards):
    """A sparse sensor set's first-round records: its screen and discovery.search_jobs shares of the
    fits (:mod:`costa.discover.sparse.split`); none on the full-state route (costa.discover.route).
    """
    sensor_set, _ = record_settings(config, wildcards.sensors, wildcards.case)
    declared = {
        s.channel: float(s.every_s) for s in sensor_set.sensors if s.every_s != "tap"
    }
    if choose_route(declared, dt_s=config["simulation"]["dt_s"]).name == "full_state":
        return {}
    prefix = out(f"discovery/{wildcards.case}/sensors/{wildcards.sensors}/search")
    jobs = config["discovery"]["search_jobs"]
    return {
        "screen": f"{prefix}/screen.pkl",
        "fits": [f"{prefix}/fit_{j}_of_{jobs}.pkl" for j in range(jobs)],
    }


LINE = Line.from_config(config["line"]) if config["line"] else None
LINE_NAME = LINE.name if LINE else "^$"
LINE_SIMULATED_POTS = "|".join(LINE.pots) if LINE and LINE.simulated else "^$"
LINE_IMPORTED_POTS = "|".join(LINE.pots) if LINE and LINE.historian else "^$"


def pot_record_path(line, pot):
    """A pot's record: simulated (rule line_pot) or imported (rule line_pot_import), or your file."""
    return LINE.records.get(pot) or out(f"line/{line}/pots/{pot}/record.parquet")


def line_historian_files(wildcards):
    """One of your pots' historian files (export, tag map, events and lab samples where given)."""
    return LINE.historian_files(wildcards.pot)


def line_record(wildcards):
    return pot_record_path(wildcards.line, wildcards.pot)


#: a line's passes: the pots grouped by their screens, then pooled again by what each correction explains
LINE_STAGES = "groups|pooled"


def _line_groups(wildcards, stage="groups"):
    """The groups of the line's checkpoint of ``stage``: the first pass (groups.json) or the second
    (pooled.json: every group, ``again`` where it is searched again)."""
    if stage == "pooled":
        groups = checkpoints.line_pooled.get(line=wildcards.line).output.groups
    else:
        groups = checkpoints.line_groups.get(line=wildcards.line).output.groups
    return json.loads(Path(groups).read_text())


def _line_group(wildcards):
    """The group of the line's checkpoint named by the wildcards (its stage's)."""
    return next(
        g
        for g in _line_groups(wildcards, wildcards.stage)
        if g["group"] == wildcards.group
    )


def line_stage_groups(wildcards):
    """The groups file of the wildcards' stage."""
    name = "groups" if wildcards.stage == "groups" else "pooled"
    return out(f"line/{wildcards.line}/{name}.json")


def line_stage_checkpoint(wildcards):
    """The first output of the wildcards' stage's checkpoint."""
    name = "line.csv" if wildcards.stage == "groups" else "pooled.json"
    return out(f"line/{wildcards.line}/{name}")


def line_flagged_pots(wildcards):
    """The pots of every group: those that disagree with the starting model, in the groups' order."""
    return [pot for g in _line_groups(wildcards) for pot in g["pots"]]


def line_flagged_screens(wildcards):
    """The screens of the pots that disagree with the starting model."""
    return [
        out(f"line/{wildcards.line}/pots/{pot}/screen.json")
        for pot in line_flagged_pots(wildcards)
    ]


def line_flagged_records(wildcards):
    """The records of the pots that disagree with the starting model."""
    return [
        pot_record_path(wildcards.line, pot) for pot in line_flagged_pots(wildcards)
    ]


def line_group_records(wildcards):
    """The records of a group's pots."""
    return [
        pot_record_path(wildcards.line, pot) for pot in _line_group(wildcards)["pots"]
    ]


def line_group_meta(wildcards):
    """What a group's findings record of its data (and, simulated, of what it hides)."""
    return group_meta(LINE, _line_group(wildcards))


def line_group_name(wildcards):
    """A group's data set name (its random streams; on a simulated line it ends in the sensor set,
    whose gap restarts and shooting cells apply); a group searched again has its own."""
    stage = "" if wildcards.stage == "groups" else "pooled/"
    name = f"line/{wildcards.line}/{stage}{wildcards.group}"
    return f"{name}/{LINE.sensors}" if LINE.simulated else name


def line_group_findings(wildcards, name="findings.json"):
    """Every first-pass group's findings (or another of its files), once the line's checkpoint has grouped the pots."""
    return [
        out(f"line/{wildcards.line}/groups/{g['group']}/{name}")
        for g in _line_groups(wildcards)
    ]


def line_group_checks(wildcards):
    """Every first-pass group's correction checked on its pots (rule line_group_check)."""
    return line_group_findings(wildcards, "pots.csv")


def line_pooled_findings(wildcards, name="findings.json"):
    """The findings (or another file) of every group the second pass searches again."""
    return [
        out(f"line/{wildcards.line}/pooled/{g['group']}/{name}")
        for g in _line_groups(wildcards, "pooled")
        if g["again"]
    ]


def line_pooled_checks(wildcards):
    """The checks of every group the second pass searches again."""
    return line_pooled_findings(wildcards, "pots.csv")


def historian_files(wildcards):
    """The export, its tag map and, where given, its events log and lab samples."""
    h = config["historian"]
    return {k: h[k] for k in ("export", "tags", "events", "lab") if h.get(k)}
