rule benchmark_signal:
    """How much a drawn case's effect shows in the record a sensor set makes: the record
    simulated with and without it, summed over the measured samples in noise units."""
    input:
        code=CASE_DATA_CODE + package_files("benchmark/signal.py"),
    output:
        signal=out("benchmark/signal/{sensors}/{case}.json"),
    log:
        out("benchmark/logs/signal/{sensors}/{case}.log"),
    wildcard_constraints:
        case=DRAWN_CASE,
        sensors="|".join(config["discovery"]["sensor_sets"]),
    conda:
        ENV
    threads: 1
    params:
        config=discovery_config,
    script:
        "../scripts/benchmark_signal.py"


rule collect_benchmark:
    """Every drawn case judged against its truth; precision and recall per sensor set with
    their intervals, recall against the signal, and the page that shows them."""
    input:
        findings=[sensor_findings(case, sensors) for case, sensors in BENCHMARK_CASES],
        signals=[
            out(f"benchmark/signal/{sensors}/{case}.json")
            for case, sensors in BENCHMARK_CASES
        ],
        peers=expand(out("peers/{case}/rows.csv"), case=BENCHMARK_PEER_CASES),
        code=package_files("benchmark", "plots", "discover/summary.py"),
    output:
        summary=report(
            out("benchmark/summary.csv"),
            category="Benchmark",
            caption="../report/captions/benchmark.rst",
        ),
        rates=out("benchmark/rates.csv"),
        curve=out("benchmark/recall_by_signal.csv"),
        by_kind=out("benchmark/strong_by_kind.csv"),
        truth_listed=out("benchmark/truth_listed.csv"),
        peers=out("benchmark/peers.csv"),
        figure=report(
            out("benchmark/recall_by_signal.png"),
            category="Benchmark",
            caption="../report/captions/benchmark.rst",
        ),
        page=out("benchmark/benchmark.md"),
    log:
        out("benchmark/logs/collect.log"),
    conda:
        ENV
    threads: 1
    params:
        sensors=[sensors for _, sensors in BENCHMARK_CASES],
        order=list(BENCHMARK_SETS),
        split=config["benchmark"]["split"],
        size=config["benchmark"]["size"],
        bins=config["benchmark"]["signal_bins"],
        sizes=config["benchmark"]["sizes"],
    script:
        "../scripts/collect_benchmark.py"


rule collect_closed_loop:
    """The closed loop of "what to measure next" over the benchmark's sparse cases: per sensor set, what
    the added measurements predicted and achieved, and the right names they gained."""
    input:
        loops=[
            out(f"discovery/{case}/sensors/{sensors}/next/loop.json")
            for case, sensors in BENCHMARK_CASES
            if sensors != "full"
        ],
        code=package_files("benchmark/closed_loop.py", "benchmark/score.py"),
    output:
        table=out("benchmark/closed_loop.csv"),
        summary=out("benchmark/closed_loop_summary.csv"),
        page=out("benchmark/closed_loop.md"),
    log:
        out("benchmark/logs/closed_loop.log"),
    conda:
        ENV
    threads: 1
    params:
        split=config["benchmark"]["split"],
    script:
        "../scripts/collect_closed_loop.py"
