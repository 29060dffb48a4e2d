"""Roll one model type out on the test set; write its metrics, per-state errors and saved forecasts."""

from costa import runtime
from costa.data import arrays, load_trajectories
from costa.evaluate import evaluate

log = runtime.configure(snakemake)
x_test, u_test = arrays(load_trajectories(snakemake.input.test))
x_train, _ = arrays(load_trajectories(snakemake.input.train))
result = evaluate(snakemake.params.config, snakemake.wildcards.model, x_test, u_test, x_train, snakemake.input.models)
result.metrics.to_parquet(snakemake.output.metrics, index=False)
result.per_state.to_parquet(snakemake.output.per_state, index=False)
result.forecasts.to_parquet(snakemake.output.forecasts, index=False)
coded = result.metrics[result.metrics.definition == "coded"]
log.info("blow-ups per window: %s", coded.groupby("window", sort=False)["blown_up"].sum().to_dict())
