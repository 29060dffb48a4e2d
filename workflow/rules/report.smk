rule report:
    """The report notebook, executed on this run's results and rendered to HTML."""
    input:
        notebook=f"{workflow.basedir}/report/report.py",
        errata=f"{workflow.basedir}/docs/errata.md",
        datasets="results/figures/datasets.png",
        training_curves="results/figures/training_curves.png",
        error_violins="results/figures/error_violins.png",
        blowups="results/figures/blowups.png",
        rolling_forecast="results/figures/rolling_forecast.png",
        summary="results/eval/summary.csv",
        claims="results/eval/claims.csv",
        per_state="results/eval/per_state_errors.parquet",
        losses=expand(
            "results/models/{model_type}/losses.parquet", model_type=MODEL_TYPES
        ),
        sparsity=expand(
            "results/models/{model_type}/sparsity.parquet", model_type=MODEL_TYPES
        ),
        benchmarks=job_benchmarks(""),
        discovery_summary=["results/discovery/summary.csv"] if DISCOVERY_CASES else [],
        discovery_figures=expand(
            "results/discovery/{case}/discovery.png", case=DISCOVERY_CASES
        ),
        discovery_findings=expand(
            "results/discovery/{case}/findings.json", case=DISCOVERY_CASES
        ),
        replicate_table=across_replicates("results/replicates/per_replicate.csv"),
        replicate_aggregate=across_replicates("results/replicates/aggregate.csv"),
        replicate_claims=across_replicates("results/replicates/claims.csv"),
        replicate_blowups=across_replicates("results/replicates/blowups.png"),
        code=package_files("report.py", "paper.py", "plots"),
    output:
        html="report/report.html",
        notebook="results/report/report.ipynb",
    log:
        "results/logs/report.log",
    benchmark:
        "results/benchmarks/report.tsv"
    conda:
        ENV
    threads: 1
    params:
        config=config,
        repository=lambda wildcards, input: str(Path(input.notebook).parents[1]),
    script:
        "../scripts/render_report.py"
