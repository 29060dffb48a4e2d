rule discovery_sensor_data:
    """Simulate a shipped case and measure it with one sensor set (discovery.sensor_sets):
    each channel at its own interval and noise, the rest unmeasured."""
    input:
        code=CASE_DATA_CODE,
    output:
        train=out("discovery/{case}/sensors/{sensors}/data/train.parquet"),
        held_out=out("discovery/{case}/sensors/{sensors}/data/held_out.parquet"),
    log:
        out("discovery/{case}/sensors/{sensors}/logs/data.log"),
    benchmark:
        out("discovery/{case}/sensors/{sensors}/benchmarks/data.tsv")
    wildcard_constraints:
        case="|".join([*SHIPPED_CASES, DRAWN_CASE]),
        sensors="|".join(config["discovery"]["sensor_sets"]),
    conda:
        ENV
    threads: 1
    params:
        config=discovery_config,
    script:
        "../scripts/discovery_case_data.py"


rule sensors_screen:
    """The first round of a sparse search, up to its candidates: the channel tests and every
    hypothesis screened (the fits run as separate jobs)."""
    input:
        train=out("discovery/{case}/sensors/{sensors}/data/train.parquet"),
        held_out=out("discovery/{case}/sensors/{sensors}/data/held_out.parquet"),  # the route reads both
        code=DISCOVERY_CODE + package_files("sensors.py"),
    output:
        screen=out("discovery/{case}/sensors/{sensors}/search/screen.pkl"),
    log:
        out("discovery/{case}/sensors/{sensors}/logs/screen.log"),
    benchmark:
        out("discovery/{case}/sensors/{sensors}/benchmarks/screen.tsv")
    wildcard_constraints:
        case="|".join([*SHIPPED_CASES, DRAWN_CASE]),
        sensors="|".join(config["discovery"]["sensor_sets"]),
    conda:
        ENV
    threads: 2  # the compiled kernels share the rows of a batch among them; nothing else runs beside a case's screen
    resources:
        mem_mb=6000,
    params:
        config=discovery_config,
        starting_model=starting_model_name,
        name=lambda wildcards: f"{wildcards.case}/{wildcards.sensors}",
        declared_noise=declared_noise,
    script:
        "../scripts/sensors_search.py"


rule sensors_fit:
    """One share of the first round's candidate fits: job {job} of {jobs} fits candidates
    {job}, {job} + {jobs}, ..."""
    input:
        train=out("discovery/{case}/sensors/{sensors}/data/train.parquet"),
        held_out=out("discovery/{case}/sensors/{sensors}/data/held_out.parquet"),
        screen=out("discovery/{case}/sensors/{sensors}/search/screen.pkl"),
        code=DISCOVERY_CODE + package_files("sensors.py"),
    output:
        fits=out("discovery/{case}/sensors/{sensors}/search/fit_{job}_of_{jobs}.pkl"),
    log:
        out("discovery/{case}/sensors/{sensors}/logs/fit_{job}_of_{jobs}.log"),
    benchmark:
        out("discovery/{case}/sensors/{sensors}/benchmarks/fit_{job}_of_{jobs}.tsv")
    wildcard_constraints:
        case="|".join([*SHIPPED_CASES, DRAWN_CASE]),
        sensors="|".join(config["discovery"]["sensor_sets"]),
        job=r"\d+",
        jobs=r"\d+",
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=6000,
    params:
        config=discovery_config,
        starting_model=starting_model_name,
        name=lambda wildcards: f"{wildcards.case}/{wildcards.sensors}",
        declared_noise=declared_noise,
    script:
        "../scripts/sensors_search.py"


rule discover_with_sensors:
    """Discovery on what one sensor set measures: the estimator's channel tests, the named (or
    not identifiable) effect, its closed form, and the gap on the measured channels."""
    input:
        unpack(split_search),
        train=out("discovery/{case}/sensors/{sensors}/data/train.parquet"),
        held_out=out("discovery/{case}/sensors/{sensors}/data/held_out.parquet"),
        code=DISCOVERY_CODE + package_files("sensors.py"),
    output:
        findings=out("discovery/{case}/sensors/{sensors}/findings.json"),
        markdown=out("discovery/{case}/sensors/{sensors}/findings.md"),
        gap=out("discovery/{case}/sensors/{sensors}/gap.parquet"),
        per_state=out("discovery/{case}/sensors/{sensors}/per_channel_errors.parquet"),
    log:
        out("discovery/{case}/sensors/{sensors}/logs/discover.log"),
    benchmark:
        out("discovery/{case}/sensors/{sensors}/benchmarks/discover.tsv")
    wildcard_constraints:
        case="|".join([*SHIPPED_CASES, DRAWN_CASE]),
        sensors="|".join(config["discovery"]["sensor_sets"]),
    conda:
        ENV
    threads: 2  # as the screen: the last job of a case
    resources:
        mem_mb=6000,
    params:
        config=discovery_config,
        meta=sensor_meta,
        starting_model=starting_model_name,
        name=lambda wildcards: f"{wildcards.case}/{wildcards.sensors}",
        declared_noise=declared_noise,
    script:
        "../scripts/discover.py"


rule collect_sensors:
    """The shipped cases under every sensor set: what was named, its closed form, the gap."""
    input:
        findings=[
            sensor_findings(case, s) for case in SHIPPED_CASES for s in SENSOR_SETS
        ],
        code=package_files("discover"),
    output:
        summary=report(
            out("discovery/sensors.csv"),
            category="Discovery",
            caption="../report/captions/discovery_sensors.rst",
        ),
    log:
        out("discovery/logs/collect_sensors.log"),
    conda:
        ENV
    threads: 1
    params:
        sensors=[s for case in SHIPPED_CASES for s in SENSOR_SETS],
    script:
        "../scripts/collect_sensors.py"


rule discover_next:
    """The closed loop: a sparse run that ended without a name, discovered again with the first
    round's top recommended measurement added (predicted and achieved in loop.json)."""
    input:
        before=out("discovery/{case}/sensors/{sensors}/findings.json"),
        train=out("discovery/{case}/sensors/{sensors}/data/train.parquet"),
        held_out=out("discovery/{case}/sensors/{sensors}/data/held_out.parquet"),
        code=DISCOVERY_CODE + CASE_DATA_CODE + package_files("benchmark/closed_loop.py"),
    output:
        findings=out("discovery/{case}/sensors/{sensors}/next/findings.json"),
        markdown=out("discovery/{case}/sensors/{sensors}/next/findings.md"),
        loop=out("discovery/{case}/sensors/{sensors}/next/loop.json"),
    log:
        out("discovery/{case}/sensors/{sensors}/logs/next.log"),
    benchmark:
        out("discovery/{case}/sensors/{sensors}/benchmarks/next.tsv")
    wildcard_constraints:
        case="|".join([*SHIPPED_CASES, DRAWN_CASE]),
        sensors="|".join(config["discovery"]["sensor_sets"]),
    conda:
        ENV
    threads: 2  # the whole search in one job
    resources:
        mem_mb=6000,
    params:
        config=discovery_config,
        meta=sensor_meta,
        starting_model=starting_model_name,
        name=lambda wildcards: f"{wildcards.case}/{wildcards.sensors}",
        declared_noise=declared_noise,
    script:
        "../scripts/discover.py"
