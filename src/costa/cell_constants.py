"""Print the cell's constants a config gives: ``python -m costa.cell_constants [config.yaml ...]``.

The files are merged over the default config as ``snakemake --configfile`` does;
the table (constant, value, unit, meaning, source) shows what ``physics.cell``
and ``physics.overrides`` make of the constants.
"""

from __future__ import annotations

import sys

import pandas as pd

from .config import DEFAULT_CONFIG, load_config
from .physics import constants_table


def main(paths: list[str]) -> None:
    config = load_config(DEFAULT_CONFIG, *paths)
    with pd.option_context("display.max_colwidth", 70, "display.width", 200):
        print(constants_table(config["physics"]).to_string(index=False))


if __name__ == "__main__":
    main(sys.argv[1:])
