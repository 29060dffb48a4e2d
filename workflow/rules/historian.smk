rule import_historian:
    """One pot's historian export on the model's step: the data contract's record and events
    (discovery.user_data reads them), and what was kept, dropped and cut."""
    input:
        unpack(historian_files),
        code=package_files("historian"),
    output:
        record=out("historian/{name}/record.parquet"),
        events=out("historian/{name}/events.csv"),
        json=out("historian/{name}/import.json"),
        markdown=out("historian/{name}/import.md"),
        plot=report(
            out("historian/{name}/channels.png"),
            category="Historian import",
            caption="../report/captions/historian.rst",
        ),
    log:
        out("historian/{name}/logs/import.log"),
    wildcard_constraints:
        name=(config["historian"] or {}).get("name", "pot"),
    conda:
        ENV
    threads: 1
    params:
        historian=lambda wildcards: config["historian"],
        dt_s=config["simulation"]["dt_s"],
    script:
        "../scripts/import_historian.py"
