"""Shared fixtures: configs and small simulated data sets."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from costa.config import load_config
from costa.physics import ablated_model, true_model
from costa.simulate import SimulationSettings

REPOSITORY = Path(__file__).resolve().parents[1]


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


def random_operating_points(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """States and inputs spread over the plausible operating range (SPEC section 4)."""
    x4 = rng.uniform(9500, 17000, n)
    c2 = rng.uniform(0.023, 0.05, n)
    c3 = rng.uniform(0.09, 0.13, n)
    bath = x4 / (1 - c2 - c3)
    x = np.column_stack([
        rng.uniform(1600, 5500, n), c2 * bath, c3 * bath, x4, rng.uniform(9760, 10000, n),
        rng.uniform(958, 988, n), rng.uniform(745, 875, n), rng.uniform(490, 680, n),
    ])  # fmt: skip
    u = np.column_stack([
        rng.uniform(0, 22, n), rng.uniform(118000, 155000, n), rng.uniform(0, 8, n),
        rng.uniform(0, 9, n), rng.uniform(0.043, 0.057, n),
    ])  # fmt: skip
    return x, u


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
