rule aggregate_replicates:
    """Blow-ups, median errors and the paper's claims across the replicates, with bootstrap intervals
    over replicates and instances."""
    input:
        summaries=expand("results/{rep}eval/summary.csv", rep=REPLICATES),
        metrics=expand("results/{rep}eval/metrics.parquet", rep=REPLICATES),
        code=package_files(
            "replicates.py", "summary.py", "claims.py", "paper.py", "seeds.py"
        ),
    output:
        per_replicate="results/replicates/per_replicate.csv",
        aggregate=report(
            "results/replicates/aggregate.csv",
            caption="../report/captions/replicate_aggregate.rst",
            category="Replicates",
        ),
        claims_by_replicate="results/replicates/claims_by_replicate.csv",
        claims=report(
            "results/replicates/claims.csv",
            caption="../report/captions/replicate_claims.rst",
            category="Replicates",
        ),
    log:
        "results/replicates/logs/aggregate_replicates.log",
    benchmark:
        "results/replicates/benchmarks/aggregate_replicates.tsv"
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
        per_replicate="results/replicates/per_replicate.csv",
        code=package_files("plots", "paper.py"),
    output:
        png=report(
            "results/replicates/blowups.png",
            caption="../report/captions/replicate_blowups.rst",
            category="Replicates",
        ),
        pdf="results/replicates/blowups.pdf",
    log:
        "results/replicates/logs/plot_replicates.log",
    benchmark:
        "results/replicates/benchmarks/plot_replicates.tsv"
    conda:
        ENV
    threads: 1
    script:
        "../scripts/plot_replicates.py"
