"""Config checking with clear messages, and loading outside Snakemake exactly as the Snakefile does."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import jsonschema
import yaml
from snakemake.utils import update_config, validate

REPOSITORY = Path(__file__).resolve().parents[2]
SCHEMA = REPOSITORY / "workflow" / "schemas" / "config.schema.yaml"
DEFAULT_CONFIG = REPOSITORY / "config" / "config.yaml"

__all__ = ["ConfigError", "check_config", "load_config"]


class ConfigError(ValueError):
    """A config that does not match the schema."""


def check_config(config: Mapping[str, Any], schema_path: str | Path = SCHEMA) -> None:
    """Raise :class:`ConfigError` naming the key of the most relevant schema violation."""
    schema = yaml.safe_load(Path(schema_path).read_text())
    error = jsonschema.exceptions.best_match(jsonschema.Draft202012Validator(schema).iter_errors(config))
    if error is not None:
        where = ".".join(map(str, error.absolute_path)) or "(top level)"
        raise ConfigError(f"invalid config at '{where}': {error.message}")


def load_config(*paths: str | Path, overrides: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Deep-merge the YAML files (later ones win) and ``overrides``, check, fill defaults."""
    config: dict[str, Any] = {}
    for path in paths or (DEFAULT_CONFIG,):
        update_config(config, yaml.safe_load(Path(path).read_text()) or {})
    update_config(config, dict(overrides or {}))
    check_config(config)
    validate(config, str(SCHEMA), set_default=True)
    return config
