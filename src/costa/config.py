"""Config checking with clear messages, and loading outside Snakemake exactly as the Snakefile does."""

from __future__ import annotations

from collections.abc import Mapping
from itertools import pairwise
from pathlib import Path
from typing import Any

import jsonschema
import yaml
from snakemake.utils import update_config, validate

REPOSITORY = Path(__file__).resolve().parents[2]
SCHEMA = REPOSITORY / "workflow" / "schemas" / "config.schema.yaml"
DEFAULT_CONFIG = REPOSITORY / "config" / "config.yaml"

__all__ = ["ConfigError", "check_config", "check_consistency", "check_user_data", "load_config"]


class ConfigError(ValueError):
    """A config that does not match the schema."""


def check_config(config: Mapping[str, Any], schema_path: str | Path = SCHEMA) -> None:
    """Raise :class:`ConfigError` naming the key of the most relevant schema violation."""
    schema = yaml.safe_load(Path(schema_path).read_text())
    error = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(schema).iter_errors(config))
    if error is not None:
        where = ".".join(map(str, error.absolute_path)) or "(top level)"
        raise ConfigError(f"invalid config at '{where}': {error.message}")


def _check_benchmark(benchmark: Mapping[str, Any], sensor_sets: Mapping[str, Any]) -> None:
    """The benchmark's size is one of its sizes, each naming sensor sets that exist, within the seed range."""
    from .discover.cases.drawn import SPLITS

    sizes = benchmark["sizes"]
    if benchmark["size"] not in sizes:
        raise ConfigError(f"benchmark.size {benchmark['size']!r} is not one of benchmark.sizes {sorted(sizes)}")
    for size, chosen in sizes.items():
        key, counts = f"benchmark.sizes.{size}", chosen["sensors"]
        unknown = sorted(set(counts) - set(sensor_sets))
        if unknown:
            raise ConfigError(f"{key}.sensors {unknown} are not in discovery.sensor_sets {sorted(sensor_sets)}")
        too_many = {s: n for s, n in counts.items() if n > len(SPLITS[benchmark["split"]])}
        if too_many:
            raise ConfigError(f"{key}.sensors {too_many}: more cases than the {benchmark['split']!r} seeds hold")
        if chosen.get("peers", 0) > counts.get("full", 0):
            raise ConfigError(f"{key}.peers: the peers run on the full set's cases, at most {counts.get('full', 0)}")
    if list(benchmark["signal_bins"]) != sorted(set(benchmark["signal_bins"])):
        raise ConfigError(f"benchmark.signal_bins {benchmark['signal_bins']} must increase")


def check_consistency(config: Mapping[str, Any]) -> None:
    """Checks across keys that a schema cannot express; raise :class:`ConfigError` naming the keys."""
    from .metrics import EvaluationSettings

    steps = config["simulation"]["steps"]
    evaluation, figures = config["evaluation"], config["figures"]
    try:
        EvaluationSettings.from_config(evaluation).check(steps)
    except ValueError as error:
        raise ConfigError(f"{error} (simulation.steps)") from None
    _check_disjoint_windows(evaluation["windows"])
    for key in ("windows", "horizons"):
        missing = sorted({"short", "medium", "long"} - set(evaluation[key]))
        if missing:
            raise ConfigError(
                f"evaluation.{key} lacks {missing}: the paper's claims and the discovery summary compare "
                "the short, medium and long windows"
            )
    tests = config["simulation"]["test_trajectories"]
    if any(t >= tests for t in evaluation["saved_trajectories"]):
        raise ConfigError(
            f"evaluation.saved_trajectories {evaluation['saved_trajectories']} must be below simulation.test_trajectories = {tests}"
        )
    if figures["rolling_forecast_trajectory"] not in evaluation["saved_trajectories"]:
        raise ConfigError(
            f"figures.rolling_forecast_trajectory = {figures['rolling_forecast_trajectory']} must be one of "
            f"evaluation.saved_trajectories {evaluation['saved_trajectories']}"
        )
    unknown = sorted(set(figures["rolling_forecast_types"]) - set(config["training"]["model_types"]))
    if unknown:
        raise ConfigError(f"figures.rolling_forecast_types {unknown} are not in training.model_types")
    unknown_sets = sorted(set(config["discovery"]["sensors"]) - set(config["discovery"]["sensor_sets"]))
    if unknown_sets:
        raise ConfigError(
            f"discovery.sensors {unknown_sets} are not in discovery.sensor_sets {sorted(config['discovery']['sensor_sets'])}"
        )
    _check_benchmark(config["benchmark"], config["discovery"]["sensor_sets"])
    for name, spec in config["discovery"]["sensor_sets"].items():
        low, high = (spec.get("vary") or {}).get("hours", (0, 0))
        if low > high:
            raise ConfigError(f"discovery.sensor_sets.{name}.vary.hours [{low}, {high}]: the low end is above the high")
    user = config["discovery"]["user_data"]
    if user and user["name"] in config["discovery"]["cases"]:
        raise ConfigError(
            f"discovery.user_data.name {user['name']!r} is also a shipped case in discovery.cases; choose another name"
        )
    _check_cell(config["physics"])
    _check_gap_windows(user)
    _check_line(config["line"], config["discovery"]["sensor_sets"])
    noise = config["beyond"]["noise"]
    unknown = sorted(set(noise["model_types"]) - set(config["training"]["model_types"]))
    if unknown:
        raise ConfigError(f"beyond.noise.model_types {unknown} are not in training.model_types")
    if noise["levels"] and noise["replicates"] > config["replicates"]:
        raise ConfigError(
            f"beyond.noise.replicates = {noise['replicates']} is more than the run's replicates = {config['replicates']}"
        )
    _check_peers(config)
    copied = evaluation["copied_samples"]
    if max(copied.values()) >= steps:
        raise ConfigError(f"evaluation.copied_samples {copied} must be below simulation.steps = {steps}")


def _check_line(line: Mapping[str, Any] | None, sensor_sets: Mapping[str, Any]) -> None:
    """A simulated line's sensor set exists, its groups are shipped cases, each pot in one group at most;
    each pot imported from a historian has a tag map (its own or the line's)."""
    historian = (line or {}).get("historian")
    for pot, files in (historian or {}).get("pots", {}).items():
        if not files.get("tags") and not historian["tags"]:
            raise ConfigError(f"line.historian.pots.{pot}: no tag map (give its tags, or line.historian.tags)")
    simulated = (line or {}).get("simulated")
    if not simulated:
        return
    from .discover.cases.shipped import CASES

    if simulated["sensors"] not in sensor_sets:
        raise ConfigError(
            f"line.simulated.sensors {simulated['sensors']!r} is not in discovery.sensor_sets {sorted(sensor_sets)}"
        )
    seen: dict[int, str] = {}
    for i, group in enumerate(simulated["groups"]):
        key = f"line.simulated.groups[{i}]"
        if group["case"] not in CASES:
            raise ConfigError(f"{key}.case {group['case']!r} is not a shipped case; known: {sorted(CASES)}")
        for pot in group["pots"]:
            if pot >= simulated["pots"]:
                raise ConfigError(f"{key}.pots: pot {pot} is beyond the line's {simulated['pots']} pots (0-based)")
            if pot in seen:
                raise ConfigError(f"{key}.pots: pot {pot} is in {seen[pot]} too; a pot hides one effect")
            seen[pot] = key


def _check_cell(physics: Mapping[str, Any]) -> None:
    from .physics import parameters_from_config

    try:
        parameters_from_config(physics["constants"], physics["overrides"], physics["cell"])
    except ValueError as error:
        raise ConfigError(str(error)) from None


def _check_gap_windows(user: Mapping[str, Any] | None) -> None:
    for name, (low, high) in ((user or {}).get("gap_windows") or {}).items():
        if not low < high:
            raise ConfigError(
                f"discovery.user_data.gap_windows.{name} = [{low}, {high}): the start must be below the stop"
            )


def _check_disjoint_windows(windows: Mapping[str, Any]) -> None:
    """The coded metric's windows must not overlap (each step counts in one window)."""
    ordered = sorted(windows.items(), key=lambda item: item[1][0])
    for (before, (_, stop)), (after, (start, end)) in pairwise(ordered):
        if start < stop:
            raise ConfigError(
                f"evaluation.windows.{after} = [{start}, {end}) overlaps evaluation.windows.{before}, "
                f"which ends at {stop}; the windows must be disjoint"
            )


def check_user_data(config: Mapping[str, Any]) -> None:
    """Read and check the measurements ``discovery.user_data.path`` names (if any) as discovery will,
    and the events ``discovery.user_data.events`` names (if any) against them.

    Raises :class:`costa.data.TrajectoryDataError` naming the key, the file and the column
    and row of the first problem, so that a bad file stops a run before anything is scheduled.
    """
    user = config["discovery"]["user_data"]
    if not user or _made_by_the_import(config, user["path"]):
        return
    from .data import TrajectoryDataError
    from .discover.pipeline import split_held_out
    from .events import load_trajectories_with_events

    try:
        split_held_out(user["path"], user["held_out_fraction"], user["unlogged_inputs"])
    except TrajectoryDataError as error:
        raise TrajectoryDataError(f"invalid data at 'discovery.user_data.path': {error}") from None
    if user.get("events"):
        try:
            load_trajectories_with_events(user["path"], user["events"], user["unlogged_inputs"])
        except TrajectoryDataError as error:
            raise TrajectoryDataError(f"invalid data at 'discovery.user_data.events': {error}") from None


def _made_by_the_import(config: Mapping[str, Any], path: str) -> bool:
    """Whether ``path`` is the record the historian import will write (checked as it is made)."""
    h = config.get("historian")
    return bool(h) and Path(path) == Path(config["output"]["results"]) / "historian" / h["name"] / "record.parquet"


def check_historian(config: Mapping[str, Any]) -> None:
    """Import the historian export ``historian`` names (if any) as the workflow will, so that a bad
    export stops a run in one line naming the file, the tag and the row before anything is scheduled;
    for a line's pots (:func:`_check_line_historian`) their files found and tag maps read."""
    _check_line_historian(config)
    if not config.get("historian"):
        return
    from .data import TrajectoryDataError
    from .historian import import_historian, read_tag_map

    h = config["historian"]
    try:
        settings = historian_settings(h, config["simulation"]["dt_s"])
        import_historian(h["export"], read_tag_map(h["tags"]), settings, h["events"], h["lab"])
    except TrajectoryDataError as error:
        raise TrajectoryDataError(f"invalid data at 'historian': {error}") from None


def historian_settings(h: Mapping[str, Any], dt_s: float):
    """The grid a historian export is put on: the model's step ``dt_s`` [s] and the ``historian`` keys ``h``."""
    from .historian import GridSettings

    return GridSettings(
        timezone=h["timezone"], step_s=dt_s, max_gap_s=h["max_gap_s"],
        anode_effect_v=h["anode_effect_v"], anode_effect_after_s=h["anode_effect_after_s"],
        anode_change_after_s=h["anode_change_after_s"],
        trajectory_s=3600.0 * h["trajectory_hours"] if h["trajectory_hours"] else None,
    )  # fmt: skip


def _check_peers(config: Mapping[str, Any]) -> None:
    from .discover.cases.unshipped import find_case

    for name in config.get("peers", {}).get("cases") or []:
        try:
            find_case(name)
        except ValueError as error:
            raise ConfigError(f"peers.cases: {error}") from None


def load_config(*paths: str | Path, overrides: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Deep-merge the YAML files (later ones win) and ``overrides``, check, fill defaults."""
    config: dict[str, Any] = {}
    for path in paths or (DEFAULT_CONFIG,):
        update_config(config, yaml.safe_load(Path(path).read_text()) or {})
    update_config(config, dict(overrides or {}))
    check_config(config)
    validate(config, str(SCHEMA), set_default=True)
    check_consistency(config)
    return config


def _check_line_historian(config: Mapping[str, Any]) -> None:
    """Each file a line's historian pots name found and each tag map read and checked, before anything
    is scheduled (each export is imported by its pot's own job, whose error names the pot)."""
    if not (config.get("line") or {}).get("historian"):
        return
    from .data import TrajectoryDataError
    from .historian import read_tag_map
    from .line.pots import Line

    line, checked = Line.from_config(config["line"]), set()
    for pot in line.pots:
        files, key = line.historian_files(pot), f"line.historian.pots.{pot}"
        for name, path in files.items():
            if path and not Path(path).is_file():
                raise TrajectoryDataError(f"invalid data at '{key}.{name}': {path} does not exist")
        if files["tags"] not in checked:
            try:
                read_tag_map(files["tags"])
            except TrajectoryDataError as error:
                raise TrajectoryDataError(f"invalid data at '{key}.tags': {error}") from None
            checked.add(files["tags"])
