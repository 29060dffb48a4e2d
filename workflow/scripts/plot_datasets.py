"""Draw the data-set figure."""

from costa import runtime
from costa.data import load_trajectories
from costa.plots import plot_datasets, save

runtime.configure(snakemake)
figure = plot_datasets(
    load_trajectories(snakemake.input.train),
    load_trajectories(snakemake.input.test),
    snakemake.params.test_trajectories,
)
save(figure, snakemake.output.png, snakemake.output.pdf)
