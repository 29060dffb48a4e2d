"""Train the instances of one model type; save each instance, the loss curves and the sparsity."""

from costa import runtime
from costa.data import arrays, load_trajectories
from costa.models import save_instance
from costa.train import train_model_type

log = runtime.configure(snakemake)
config = snakemake.params.config
x, u = arrays(load_trajectories(snakemake.input.train))
fitted = train_model_type(config, snakemake.wildcards.model_type, x, u, snakemake.params.replicate, log)
final = fitted.losses[fitted.losses.epoch == fitted.losses.epoch.max()].set_index("instance")
for member, path in enumerate(snakemake.output.models):
    summary = final.loc[member, ["mse", "l1_penalty", "loss"]].astype(float).to_dict()
    save_instance(path, fitted.ensemble, member, fitted.model_type, fitted.normalisation, config, summary)
fitted.losses.to_parquet(snakemake.output.losses, index=False)
fitted.sparsity.to_parquet(snakemake.output.sparsity, index=False)
log.info("final mse per instance: %s", final["mse"].round(5).tolist())
