rule rollout:
    """Roll one model type (or the PBM) out on every test trajectory and score it (SPEC section 6)."""
    input:
        test=out("{rep}data/test.parquet"),
        train=out("{rep}data/train.parquet"),
        models=trained_instances,
        code=EVALUATION_CODE,
    output:
        metrics=out("{rep}eval/{model}/metrics.parquet"),
        per_state=out("{rep}eval/{model}/per_state_errors.parquet"),
        forecasts=out("{rep}eval/{model}/forecasts.parquet"),
    log:
        out("{rep}logs/rollout_{model}.log"),
    benchmark:
        out("{rep}benchmarks/rollout_{model}.tsv")
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=3000,
    params:
        config=lambda wildcards: {
            key: config[key] for key in ("physics", "simulation", "evaluation")
        },
    script:
        "../scripts/rollout.py"


rule collect_evaluation:
    """All rollouts in one table, and the summary per type and window with bootstrap intervals."""
    input:
        metrics=expand(out("{{rep}}eval/{model}/metrics.parquet"), model=EVALUATED),
        per_state=expand(
            out("{{rep}}eval/{model}/per_state_errors.parquet"), model=EVALUATED
        ),
        code=package_files("summary.py", "claims.py", "paper.py"),
    output:
        metrics=out("{rep}eval/metrics.parquet"),
        per_state=out("{rep}eval/per_state_errors.parquet"),
        summary=report(
            out("{rep}eval/summary.csv"),
            caption="../report/captions/summary.rst",
            category="Results",
        ),
        claims=report(
            out("{rep}eval/claims.csv"),
            caption="../report/captions/claims.rst",
            category="Results",
        ),
    log:
        out("{rep}logs/collect_evaluation.log"),
    benchmark:
        out("{rep}benchmarks/collect_evaluation.tsv")
    conda:
        ENV
    threads: 1
    params:
        bootstrap=config["evaluation"]["bootstrap"],
        seed=config["seed"],
        size={key: config[key] for key in ("simulation", "training", "evaluation")},
    script:
        "../scripts/collect_evaluation.py"
