rule report:
    """The report notebook, executed on this run's results and rendered to HTML."""
    input:
        notebook=checkout_file("report/report.py"),
        errata=checkout_file("docs/errata.md"),
        datasets=out("figures/datasets.png"),
        training_curves=out("figures/training_curves.png"),
        error_violins=out("figures/error_violins.png"),
        blowups=out("figures/blowups.png"),
        rolling_forecast=out("figures/rolling_forecast.png"),
        summary=out("eval/summary.csv"),
        claims=out("eval/claims.csv"),
        per_state=out("eval/per_state_errors.parquet"),
        losses=expand(out("models/{model_type}/losses.parquet"), model_type=MODEL_TYPES),
        sparsity=expand(
            out("models/{model_type}/sparsity.parquet"), model_type=MODEL_TYPES
        ),
        benchmarks=job_benchmarks(""),
        discovery_summary=[out("discovery/summary.csv")] if DISCOVERY_CASES else [],
        discovery_figures=expand(
            out("discovery/{case}/discovery.png"), case=DISCOVERY_CASES
        ),
        discovery_findings=expand(
            out("discovery/{case}/findings.json"), case=DISCOVERY_CASES
        ),
        replicate_table=across_replicates(out("replicates/per_replicate.csv")),
        replicate_aggregate=across_replicates(out("replicates/aggregate.csv")),
        replicate_claims=across_replicates(out("replicates/claims.csv")),
        replicate_blowups=across_replicates(out("replicates/blowups.png")),
        beyond_findings=expand(out("eval/{model}/findings.json"), model=DISCOVERED),
        noise_table=beyond_targets(),
        peers_summary=[out("peers/summary.csv")] if config["peers"]["in_report"] else [],
        code=package_files("report.py", "offline.html.j2", "paper.py", "plots"),
    output:
        html=f"{REPORT}/report.html",
        notebook=out("report/report.ipynb"),
    log:
        out("logs/report.log"),
    benchmark:
        out("benchmarks/report.tsv")
    conda:
        ENV
    threads: 1
    params:
        config=config,
        repository=lambda wildcards, input: str(Path(input.notebook).parents[1]),
    script:
        "../scripts/render_report.py"


rule results_page:
    """This run's result tables as Markdown: docs/results.md is this page from the default run."""
    input:
        summary=out("eval/summary.csv"),
        discovery=[out("discovery/summary.csv")] if DISCOVERY_CASES else [],
        code=package_files("paper.py", "summary.py", "kernels.py"),
    output:
        page=out("results.md"),
    log:
        out("logs/results_page.log"),
    conda:
        ENV
    threads: 1
    params:
        config=config,
        discovery_columns=[
            "case",
            "hidden",
            "named",
            "correct",
            "closed_form",
            "error_before",
            "error_after",
            "error_costa_reference",
            "noise_floor",
            "shrink_above_noise_floor",
        ],
    script:
        "../scripts/results_page.py"
