rule discovery_case_data:
    """Simulate a shipped case with its hidden effect and add measurement noise."""
    input:
        code=CASE_DATA_CODE,
    output:
        train=out("discovery/{case}/data/train.parquet"),
        held_out=out("discovery/{case}/data/held_out.parquet"),
    log:
        out("discovery/{case}/logs/data.log"),
    benchmark:
        out("discovery/{case}/benchmarks/data.tsv")
    wildcard_constraints:
        case="|".join([*SIMULATED_CASES, DRAWN_CASE]),
    conda:
        ENV
    threads: 1
    params:
        config=discovery_config,
    script:
        "../scripts/discovery_case_data.py"


rule discovery_user_events:
    """Add the rates of your events (taps, AlF3 additions, alumina doses) to your record's u4, u3 and u1."""
    input:
        record=lambda wildcards: config["discovery"]["user_data"]["path"],
        events=lambda wildcards: config["discovery"]["user_data"]["events"],
        code=package_files("data.py", "events.py", "variables.py"),
    output:
        measurements=out("discovery/{case}/data/measurements.parquet"),
    log:
        out("discovery/{case}/logs/events.log"),
    wildcard_constraints:
        case=USER_CASE or "^$",
    conda:
        ENV
    threads: 1
    params:
        unlogged=lambda wildcards: config["discovery"]["user_data"]["unlogged_inputs"],
    script:
        "../scripts/discovery_user_events.py"


rule discovery_user_data:
    """Split your own measurements into trajectories to learn from and held-out ones."""
    input:
        measurements=user_measurements,
    output:
        train=out("discovery/{case}/data/train.parquet"),
        held_out=out("discovery/{case}/data/held_out.parquet"),
    log:
        out("discovery/{case}/logs/data.log"),
    wildcard_constraints:
        case=USER_CASE or "^$",
    conda:
        ENV
    threads: 1
    params:
        fraction=lambda wildcards: config["discovery"]["user_data"]["held_out_fraction"],
        unlogged=lambda wildcards: config["discovery"]["user_data"]["unlogged_inputs"],
    script:
        "../scripts/discovery_user_data.py"


rule discover:
    """Find which equations disagree with the data, name the missing effect, correct the
    model and measure the gap before and after on held-out trajectories."""
    input:
        train=out("discovery/{case}/data/train.parquet"),
        held_out=out("discovery/{case}/data/held_out.parquet"),
        code=DISCOVERY_CODE,
    output:
        findings=report(
            out("discovery/{case}/findings.json"),
            category="Discovery",
            caption="../report/captions/discovery.rst",
        ),
        markdown=out("discovery/{case}/findings.md"),
        gap=out("discovery/{case}/gap.parquet"),
        per_state=out("discovery/{case}/per_state_errors.parquet"),
    log:
        out("discovery/{case}/logs/discover.log"),
    benchmark:
        out("discovery/{case}/benchmarks/discover.tsv")
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=4000,
    params:
        config=discovery_config,
        meta=discovery_meta,
        starting_model=starting_model_name,
        name=lambda wildcards: wildcards.case,
        declared_noise=declared_noise,
    script:
        "../scripts/discover.py"


rule discovery_costa_reference:
    """A CoSTA network correction of the same starting model, trained on the same data."""
    input:
        train=out("discovery/{case}/data/train.parquet"),
        held_out=out("discovery/{case}/data/held_out.parquet"),
        code=DISCOVERY_CODE + TRAINING_CODE,
    output:
        gap=out("discovery/{case}/costa_reference_gap.parquet"),
    log:
        out("discovery/{case}/logs/costa_reference.log"),
    benchmark:
        out("discovery/{case}/benchmarks/costa_reference.tsv")
    conda:
        ENV
    threads: 1
    params:
        config=discovery_config,
        starting_model=starting_model_name,
    script:
        "../scripts/discovery_costa_reference.py"


rule plot_discovery:
    """Equations' disagreement round by round, and the gap before and after."""
    input:
        findings=out("discovery/{case}/findings.json"),
        gap=out("discovery/{case}/gap.parquet"),
        costa=out("discovery/{case}/costa_reference_gap.parquet"),
        code=package_files("plots"),
    output:
        png=report(
            out("discovery/{case}/discovery.png"),
            category="Discovery",
            caption="../report/captions/discovery.rst",
        ),
    log:
        out("discovery/{case}/logs/plot.log"),
    conda:
        ENV
    threads: 1
    script:
        "../scripts/plot_discovery.py"


rule collect_discovery:
    """One row per case: what was hidden, what was found, the gap before and after."""
    input:
        findings=expand(out("discovery/{case}/findings.json"), case=DISCOVERY_CASES),
        costa=expand(
            out("discovery/{case}/costa_reference_gap.parquet"),
            case=DISCOVERY_CASES,
        ),
        code=package_files("discover"),
    output:
        summary=report(
            out("discovery/summary.csv"),
            category="Discovery",
            caption="../report/captions/discovery_summary.rst",
        ),
    log:
        out("discovery/logs/collect.log"),
    conda:
        ENV
    threads: 1
    script:
        "../scripts/collect_discovery.py"
