"""Make the worked example's measurements: a cell unlike the paper's, with a heat loss its model lacks.

    PYTHONPATH=src python examples/own-cell/make_data.py [path]   # default: examples/own-cell/cell.csv

A stand-in for your logged data: 6 trajectories of 400 steps of 10 s, simulated with
the cell of ``config.yaml`` (``physics.cell``) and the input excitation of the smoke
config (input holds short enough to vary within 400 steps), plus a heat loss
through the top, 22 W/K (x6 - k16), that the model does not have, and measurement
noise of 1 % of each state's spread.  Values are written with 6 significant digits.
"""

import sys
from pathlib import Path

from costa import seeds
from costa.config import DEFAULT_CONFIG, REPOSITORY, load_config
from costa.data import to_table
from costa.discover import CASES, add_noise
from costa.physics import model_from_config
from costa.simulate import SimulationSettings, simulate_set

HERE = Path(__file__).resolve().parent
TRAJECTORIES = 6


def main(path: Path = HERE / "cell.csv") -> None:
    config = load_config(DEFAULT_CONFIG, REPOSITORY / "config" / "smoke.yaml", HERE / "config.yaml")
    settings = SimulationSettings.from_config(config["simulation"])
    true, _ = CASES["top_heat_loss"].models(model_from_config(config["physics"])[0])
    simulated, _ = simulate_set(true, settings, TRAJECTORIES, config["seed"], 0, "examples/own-cell")
    rng = seeds.numpy_generator(config["seed"], 0, "examples/own-cell/noise")
    table = to_table(add_noise(simulated.x, 0.01, rng), simulated.u, settings.dt).drop(columns=["step"])
    table.to_csv(path, index=False, float_format="%.6g")


if __name__ == "__main__":
    main(*map(Path, sys.argv[1:2]))
