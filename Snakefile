# CoSTA aluminum-cell workflow: config -> data -> models -> rollouts -> figures -> report.
# This file is the table of contents; each stage lives in workflow/rules/.
import sys

from snakemake.utils import min_version, validate

min_version("9.0")


report: "workflow/report/workflow.rst"


configfile: f"{workflow.basedir}/config/config.yaml"


sys.path.insert(0, f"{workflow.basedir}/src")
from costa.config import (  # noqa: E402
    ConfigError,
    check_config,
    check_consistency,
    check_historian,
    check_user_data,
)
from costa.data import TrajectoryDataError  # noqa: E402

# One message naming the offending key, then defaults, then checks across keys, then
# your data file: a bad input stops the run in one line before anything is scheduled.
try:
    check_config(config)
    validate(
        config,
        f"{workflow.basedir}/workflow/schemas/config.schema.yaml",
        set_default=True,
    )
    check_consistency(config)
    check_user_data(config)
    check_historian(config)
except (ConfigError, TrajectoryDataError) as error:
    sys.exit(str(error))


include: "workflow/rules/common.smk"
include: "workflow/rules/simulate.smk"
include: "workflow/rules/train.smk"
include: "workflow/rules/evaluate.smk"
include: "workflow/rules/figures.smk"
include: "workflow/rules/historian.smk"
include: "workflow/rules/discover.smk"
include: "workflow/rules/sensors.smk"
include: "workflow/rules/replicates.smk"
include: "workflow/rules/beyond.smk"
include: "workflow/rules/peers.smk"
include: "workflow/rules/benchmark.smk"
include: "workflow/rules/line.smk"
include: "workflow/rules/report.smk"


rule all:
    default_target: True
    input:
        all_targets(),
