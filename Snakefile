# CoSTA aluminum-cell workflow: config -> data -> models -> rollouts -> figures -> report.
# This file is the table of contents; each stage lives in workflow/rules/.
import sys

from snakemake.utils import min_version, validate

min_version("9.0")


report: "workflow/report/workflow.rst"


configfile: f"{workflow.basedir}/config/config.yaml"


sys.path.insert(0, f"{workflow.basedir}/src")
from costa.config import check_config, check_consistency  # noqa: E402

# One message naming the offending key, then defaults, then checks across keys.
check_config(config)
validate(
    config, f"{workflow.basedir}/workflow/schemas/config.schema.yaml", set_default=True
)
check_consistency(config)


include: "workflow/rules/common.smk"
include: "workflow/rules/simulate.smk"
include: "workflow/rules/train.smk"
include: "workflow/rules/evaluate.smk"
include: "workflow/rules/figures.smk"
include: "workflow/rules/discover.smk"
include: "workflow/rules/sensors.smk"
include: "workflow/rules/replicates.smk"
include: "workflow/rules/peers.smk"
include: "workflow/rules/report.smk"


rule all:
    default_target: True
    input:
        all_targets(),
