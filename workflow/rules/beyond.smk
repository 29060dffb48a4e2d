# Past the paper's forecasts (config/beyond.yaml): the discovered model on the paper's test
# set, the noise study, and the stable CoSTA variant (a model type: training.model_types).
# With the default config no rule of this file is scheduled (the lists in common.smk are empty).
rule noisy_training_set:
    """The replicate's training set with measurement noise of {level} % of each state's std."""
    input:
        train=out("{base}data/train.parquet"),
        code=SIMULATION_CODE
        + package_files(
            "beyond.py", "discover/cases/shipped.py", "discover/cases/shipped.yaml"
        ),
    output:
        train=out("{base}noise/{level}/data/train.parquet"),
    log:
        out("{base}noise/{level}/logs/noisy_training_set.log"),
    benchmark:
        out("{base}noise/{level}/benchmarks/noisy_training_set.tsv")
    wildcard_constraints:
        base=REPLICATE_PATTERN,
        level=r"[0-9.]+",
    conda:
        ENV
    threads: 1
    params:
        seed=config["seed"],
        replicate=lambda wildcards: replicate_number(wildcards.base),
    script:
        "../scripts/noisy_training_set.py"


rule rollout_discovered:
    """Discovery on the training set from the ablated PBM; its corrected model rolled out on
    the test set like the PBM (model "discovered")."""
    input:
        train=out("{rep}data/train.parquet"),
        clean_train=lambda wildcards: out(
            f"{clean_prefix(wildcards.rep)}data/train.parquet"
        ),
        test=lambda wildcards: out(f"{clean_prefix(wildcards.rep)}data/test.parquet"),
        code=EVALUATION_CODE + DISCOVERY_CODE + package_files("beyond.py"),
    output:
        metrics=out("{rep}eval/discovered/metrics.parquet"),
        per_state=out("{rep}eval/discovered/per_state_errors.parquet"),
        forecasts=out("{rep}eval/discovered/forecasts.parquet"),
        findings=out("{rep}eval/discovered/findings.json"),
    log:
        out("{rep}logs/rollout_discovered.log"),
    benchmark:
        out("{rep}benchmarks/rollout_discovered.tsv")
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=4000,
    params:
        # what a discovery run reads (not the training settings: changing them retrains, not rediscovers)
        config=lambda wildcards: {
            key: config[key]
            for key in ("seed", "physics", "simulation", "evaluation", "discovery")
        },
        # a noisy training set needs no floor; the clean one does (schema: beyond.floor_noise)
        floor_noise=lambda wildcards: (
            0.0 if "noise/" in wildcards.rep else config["beyond"]["floor_noise"]
        ),
        name=lambda wildcards: f"{wildcards.rep}training_set",
    script:
        "../scripts/rollout_discovered.py"


rule collect_noise:
    """Blow-ups and median errors per noise level, model type and window, and their figure."""
    input:
        metrics=[path for *_, path in NOISE_RUNS],
        code=package_files("beyond.py", "replicates.py", "summary.py", "plots"),
    output:
        table=out("beyond/noise.csv"),
        png=report(
            out("beyond/noise.png"),
            caption="../report/captions/noise.rst",
            category="Beyond the paper",
        ),
        pdf=out("beyond/noise.pdf"),
    log:
        out("beyond/logs/collect_noise.log"),
    benchmark:
        out("beyond/benchmarks/collect_noise.tsv")
    conda:
        ENV
    threads: 1
    params:
        runs=[run[:3] for run in NOISE_RUNS],
        bootstrap=config["evaluation"]["bootstrap"],
        seed=config["seed"],
    script:
        "../scripts/collect_noise.py"
