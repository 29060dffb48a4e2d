# Discovery against its peers: PySINDy and the UDE recipe on the same cases (docs/discovery.md).
# PEER_CASES (common.smk): peers.cases, or every shipped case and every unshipped effect.


rule peers_case:
    """One case through PySINDy and the UDE recipe, beside this workflow's findings on the same data."""
    input:
        train=out("discovery/{case}/data/train.parquet"),
        held_out=out("discovery/{case}/data/held_out.parquet"),
        findings=out("discovery/{case}/findings.json"),
        code=PEERS_CODE,
    output:
        rows=out("peers/{case}/rows.csv"),
        details=out("peers/{case}/peers.json"),
    log:
        out("peers/{case}/logs/peers.log"),
    benchmark:
        out("peers/{case}/benchmarks/peers.tsv")
    wildcard_constraints:
        case="|".join([*PEER_CASES, DRAWN_CASE]),
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=4000,
    params:
        config=peers_config,
    script:
        "../scripts/peers_case.py"


rule collect_peers:
    """One table: per case and method, what it changed and named, its coefficients, the gap, the time."""
    input:
        rows=expand(out("peers/{case}/rows.csv"), case=PEER_CASES),
        code=package_files("peers"),
    output:
        summary=report(
            out("peers/summary.csv"),
            category="Peers",
            caption="../report/captions/peers_summary.rst",
        ),
    log:
        out("peers/logs/collect.log"),
    conda:
        ENV
    threads: 1
    script:
        "../scripts/collect_peers.py"
