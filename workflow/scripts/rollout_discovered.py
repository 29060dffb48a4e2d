"""Discovery on a training set from the ablated PBM; roll the corrected model out on the test set."""

import json

from costa import runtime
from costa.beyond import discover_on_training_set
from costa.data import arrays, load_trajectories
from costa.discover.findings import findings
from costa.discover.pipeline import starting_model
from costa.evaluate import DISCOVERED, evaluate

log = runtime.configure(snakemake)
config = snakemake.params.config
test = load_trajectories(snakemake.input.test)
# the gap inside the findings is measured on the first held_out_trajectories test trajectories;
# the evaluation below scores every one
held_out = test[test["trajectory"] < test["trajectory"].min() + config["discovery"]["held_out_trajectories"]]
result = discover_on_training_set(
    config, load_trajectories(snakemake.input.train), held_out, snakemake.params.name, snakemake.params.floor_noise
)
meta = {"data": f"{snakemake.input.train} (+ {snakemake.params.floor_noise:.1%} noise floor)"}
with open(snakemake.output.findings, "w") as handle:
    json.dump(findings(result, snakemake.params.name, starting_model(config, "ablated"), meta), handle, indent=1)
x_test, u_test = arrays(test)
x_train, _ = arrays(load_trajectories(snakemake.input.clean_train))
scored = evaluate(config, DISCOVERED, x_test, u_test, x_train, physics=result.corrected)
scored.metrics.to_parquet(snakemake.output.metrics, index=False)
scored.per_state.to_parquet(snakemake.output.per_state, index=False)
scored.forecasts.to_parquet(snakemake.output.forecasts, index=False)
coded = scored.metrics[scored.metrics.definition == "coded"]
log.info(
    "corrected model %s in %.1f s; blow-ups per window: %s",
    result.corrected.name,
    result.seconds,
    coded.groupby("window", sort=False)["blown_up"].sum().to_dict(),
)
