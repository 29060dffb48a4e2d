"""Draw the rolling-forecast figure of the configured test trajectory."""

import pandas as pd

from costa import runtime
from costa.data import load_trajectories
from costa.plots import plot_rolling_forecast, save

runtime.configure(snakemake)
trajectory = snakemake.params.trajectory
test = load_trajectories(snakemake.input.test)
forecasts = pd.concat([pd.read_parquet(p) for p in snakemake.input.forecasts], ignore_index=True)
figure = plot_rolling_forecast(
    test[test["trajectory"] == trajectory],
    forecasts[forecasts["trajectory"] == trajectory],
    snakemake.params.types,
    physics=snakemake.params.physics,
    physics_liquidus=snakemake.params.liquidus,
)
save(figure, snakemake.output.png, snakemake.output.pdf)
