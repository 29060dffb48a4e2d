rule aggregate_replicates:
    """Blow-ups, median errors and the paper's claims across the replicates, with bootstrap intervals
    over replicates and instances."""
    input:
        summaries=expand(out("{rep}eval/summary.csv"), rep=REPLICATES),
        metrics=expand(out("{rep}eval/metrics.parquet"), rep=REPLICATES),
        code=package_files(
            "replicates.py", "summary.py", "claims.py", "paper.py", "seeds.py"
        ),
    output:
        per_replicate=out("replicates/per_replicate.csv"),
        aggregate=report(
            out("replicates/aggregate.csv"),
            caption="../report/captions/replicate_aggregate.rst",
            category="Replicates",
        ),
        claims_by_replicate=out("replicates/claims_by_replicate.csv"),
        claims=report(
            out("replicates/claims.csv"),
            caption="../report/captions/replicate_claims.rst",
            category="Replicates",
        ),
    log:
        out("replicates/logs/aggregate_replicates.log"),
    benchmark:
        out("replicates/benchmarks/aggregate_replicates.tsv")
    conda:
        ENV
    threads: 1
    params:
        bootstrap=config["evaluation"]["bootstrap"],
        seed=config["seed"],
    script:
        "../scripts/aggregate_replicates.py"


rule plot_replicates:
    """Blow-ups per model type and window, one point per replicate, the paper's count marked."""
    input:
        per_replicate=out("replicates/per_replicate.csv"),
        code=package_files("plots", "paper.py"),
    output:
        png=report(
            out("replicates/blowups.png"),
            caption="../report/captions/replicate_blowups.rst",
            category="Replicates",
        ),
        pdf=out("replicates/blowups.pdf"),
    log:
        out("replicates/logs/plot_replicates.log"),
    benchmark:
        out("replicates/benchmarks/plot_replicates.tsv")
    conda:
        ENV
    threads: 1
    script:
        "../scripts/plot_replicates.py"
