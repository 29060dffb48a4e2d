"""Draw the blow-ups of every replicate beside the paper's."""

import pandas as pd

from costa import runtime
from costa.paper import paper_blowups
from costa.plots import plot_replicate_blowups, save

runtime.configure(snakemake)
per_replicate = pd.read_csv(snakemake.input.per_replicate)
save(plot_replicate_blowups(per_replicate, paper_blowups()), snakemake.output.png, snakemake.output.pdf)
