"""Config validation: defaults fill in, unknown keys and wrong types are named."""

from __future__ import annotations

import pytest
import yaml
from conftest import REPOSITORY

from costa.config import ConfigError, check_consistency, load_config


def test_schema_defaults_are_the_default_config(tmp_path):
    empty = tmp_path / "empty.yaml"
    empty.write_text("{}\n")
    assert load_config(empty) == load_config(REPOSITORY / "config" / "config.yaml")


def test_smoke_config_is_a_small_variant_of_the_default():
    smoke = load_config(REPOSITORY / "config" / "config.yaml", REPOSITORY / "config" / "smoke.yaml")
    assert smoke["simulation"]["steps"] < 1000
    assert smoke["physics"] == load_config()["physics"]


@pytest.mark.parametrize(
    ("override", "message"),
    [
        (
            {"simulaton": {}},
            r"at '\(top level\)': Additional properties are not allowed \('simulaton' was unexpected\)",
        ),
        ({"simulation": {"steps": "many"}}, r"at 'simulation.steps': 'many' is not of type 'integer'"),
        ({"simulation": {"dt_s": -1}}, r"at 'simulation.dt_s': -1 is less than or equal to the minimum of 0"),
        ({"physics": {"equations": "latest"}}, r"at 'physics.equations': 'latest' is not one of"),
        ({"physics": {"overrides": {"k99": 1.0}}}, r"at 'physics.overrides'"),
        ({"simulation": {"initial_conditions": {"x1": [1, 2, 3]}}}, r"at 'simulation.initial_conditions.x1'"),
        (
            {"discovery": {"sensor_sets": {"regimes": {"vary": {"operation": ["daily"], "hours": [24, 48],
                                                                "every_s": [3600]}}}}},
            r"at 'discovery.sensor_sets.regimes.vary.operation.0': 'daily' is not one of",
        ),
        (
            {"discovery": {"sensor_sets": {"regimes": {"vary": {"operation": ["pot_line"], "hours": [240, 24],
                                                                "every_s": [3600]}}}}},
            r"discovery.sensor_sets.regimes.vary.hours \[240, 24\]: the low end is above the high",
        ),
    ],
)  # fmt: skip
def test_bad_config_names_the_key(override, message):
    with pytest.raises(ConfigError, match=message):
        load_config(overrides=override)


def test_every_default_key_is_documented_in_the_schema():
    schema = yaml.safe_load((REPOSITORY / "workflow" / "schemas" / "config.schema.yaml").read_text())
    config = yaml.safe_load((REPOSITORY / "config" / "config.yaml").read_text())
    assert set(config) <= set(schema["properties"])


def test_the_paper_windows_must_be_named():
    config = load_config()
    del config["evaluation"]["windows"]["medium"]
    with pytest.raises(ConfigError, match=r"evaluation.windows lacks \['medium'\]"):
        check_consistency(config)
