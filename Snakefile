# CoSTA aluminum-cell workflow: config -> data -> models -> rollouts -> figures -> report.
# This file is the table of contents; each stage lives in workflow/rules/.
import sys

from snakemake.utils import min_version, validate

min_version("9.0")


configfile: f"{workflow.basedir}/config/config.yaml"


sys.path.insert(0, f"{workflow.basedir}/src")
from costa.config import check_config  # noqa: E402

check_config(config)  # one message naming the offending key
validate(
    config, f"{workflow.basedir}/workflow/schemas/config.schema.yaml", set_default=True
)


include: "workflow/rules/common.smk"
include: "workflow/rules/simulate.smk"
include: "workflow/rules/train.smk"
include: "workflow/rules/figures.smk"


rule all:
    default_target: True
    input:
        all_targets(),
