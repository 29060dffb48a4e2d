rule line_pot:
    """One simulated pot's record: one cell run and measured as the line's sensor set says,
    with the hidden effect of its group, from the pot's own streams."""
    input:
        code=CASE_DATA_CODE + package_files("line/pots.py"),
    output:
        record=out("line/{line}/pots/{pot}/record.parquet"),
    log:
        out("line/{line}/pots/{pot}/logs/record.log"),
    benchmark:
        out("line/{line}/pots/{pot}/benchmarks/record.tsv")
    wildcard_constraints:
        line=LINE_NAME,
        pot=LINE_SIMULATED_POTS,
    conda:
        ENV
    threads: 1
    params:
        config=lambda wildcards: config,
    script:
        "../scripts/line_pot.py"


rule line_pot_import:
    """One of your pots from its historian export: imported on the model's step (its import
    report and figure beside it), its events added to its inputs."""
    input:
        unpack(line_historian_files),
        code=package_files("historian", "events.py", "line/pots.py"),
    output:
        record=out("line/{line}/pots/{pot}/record.parquet"),
        report=out("line/{line}/pots/{pot}/historian/import.md"),
        figure=report(
            out("line/{line}/pots/{pot}/historian/channels.png"),
            category="Pot line",
            subcategory="Historian imports",
            caption="../report/captions/historian.rst",
        ),
    log:
        out("line/{line}/pots/{pot}/logs/import.log"),
    benchmark:
        out("line/{line}/pots/{pot}/benchmarks/import.tsv")
    wildcard_constraints:
        line=LINE_NAME,
        pot=LINE_IMPORTED_POTS,
    conda:
        ENV
    threads: 1
    params:
        config=lambda wildcards: config,
    script:
        "../scripts/line_pot_import.py"


rule line_screen:
    """One pot screened with the starting model: its filter's channel tests."""
    input:
        record=line_record,
        code=DISCOVERY_CODE + package_files("line/screen.py", "line/pots.py"),
    output:
        screen=out("line/{line}/pots/{pot}/screen.json"),
    log:
        out("line/{line}/pots/{pot}/logs/screen.log"),
    benchmark:
        out("line/{line}/pots/{pot}/benchmarks/screen.tsv")
    wildcard_constraints:
        line=LINE_NAME,
    conda:
        ENV
    threads: 1
    params:
        config=lambda wildcards: config,
    script:
        "../scripts/line_screen.py"


checkpoint line_groups:
    """The line's table (pots x channels), its figure, and the pots that disagree alike grouped."""
    input:
        screens=lambda wildcards: [
            out(f"line/{wildcards.line}/pots/{pot}/screen.json") for pot in LINE.pots
        ],
        code=package_files("line/groups.py", "line/pots.py", "plots"),
    output:
        table=out("line/{line}/line.csv"),
        groups=out("line/{line}/groups.json"),
        figure=report(
            out("line/{line}/line.png"),
            category="Pot line",
            caption="../report/captions/line.rst",
        ),
    log:
        out("line/{line}/logs/groups.log"),
    wildcard_constraints:
        line=LINE_NAME,
    conda:
        ENV
    threads: 1
    params:
        config=lambda wildcards: config,
    script:
        "../scripts/line_groups.py"


rule line_group_data:
    """A group's pots pooled into one data set, split into pots to learn from and held out (the
    first pass's groups, or the second pass's, stage pooled)."""
    input:
        groups=line_stage_groups,
        records=line_group_records,
        code=package_files("line/groups.py", "discover/pipeline.py"),
    output:
        record=out("line/{line}/{stage}/{group}/record.parquet"),
        train=out("line/{line}/{stage}/{group}/data/train.parquet"),
        held_out=out("line/{line}/{stage}/{group}/data/held_out.parquet"),
    log:
        out("line/{line}/{stage}/{group}/logs/data.log"),
    wildcard_constraints:
        line=LINE_NAME,
        stage=LINE_STAGES,
    conda:
        ENV
    threads: 1
    params:
        config=lambda wildcards: config,
    script:
        "../scripts/line_group_data.py"


rule line_group_discovery:
    """Discovery on one group's pots together: one name, one closed form for all of them."""
    input:
        # the stage's checkpoint output: a cluster job reads the checkpoint in its params only where it is an input
        checkpoint=line_stage_checkpoint,
        train=out("line/{line}/{stage}/{group}/data/train.parquet"),
        held_out=out("line/{line}/{stage}/{group}/data/held_out.parquet"),
        code=DISCOVERY_CODE,
    output:
        findings=out("line/{line}/{stage}/{group}/findings.json"),
        markdown=out("line/{line}/{stage}/{group}/findings.md"),
        gap=out("line/{line}/{stage}/{group}/gap.parquet"),
        per_state=out("line/{line}/{stage}/{group}/per_channel_errors.parquet"),
    log:
        out("line/{line}/{stage}/{group}/logs/discover.log"),
    benchmark:
        out("line/{line}/{stage}/{group}/benchmarks/discover.tsv")
    wildcard_constraints:
        line=LINE_NAME,
        stage=LINE_STAGES,
    conda:
        ENV
    threads: 2
    resources:
        mem_mb=6000,
    params:
        config=discovery_config,
        meta=line_group_meta,
        starting_model=lambda wildcards: LINE.starting_model,
        name=line_group_name,
        declared_noise=lambda wildcards: LINE.declared_noise(config),
    script:
        "../scripts/discover.py"


rule line_group_check:
    """The group's one correction checked on every pot that disagrees, alone (under the starting
    model, its screen's tests): which of its own it leaves disagreeing, which of the others it explains.
    """
    input:
        checkpoint=line_stage_checkpoint,  # as above
        findings=out("line/{line}/{stage}/{group}/findings.json"),
        records=line_flagged_records,
        screens=line_flagged_screens,
        code=DISCOVERY_CODE + package_files("line/check.py", "line/pots.py"),
    output:
        pots=out("line/{line}/{stage}/{group}/pots.csv"),
    log:
        out("line/{line}/{stage}/{group}/logs/check.log"),
    benchmark:
        out("line/{line}/{stage}/{group}/benchmarks/check.tsv")
    wildcard_constraints:
        line=LINE_NAME,
        stage=LINE_STAGES,
    conda:
        ENV
    threads: 1
    params:
        config=lambda wildcards: config,
        pots=line_flagged_pots,
        members=lambda wildcards: _line_group(wildcards)["pots"],
    script:
        "../scripts/line_group_check.py"


checkpoint line_pooled:
    """The second pass's groups: a pot its own group's correction leaves disagreeing and another's
    explains moves to that group; the groups whose pots changed are searched again."""
    input:
        groups=out("line/{line}/groups.json"),
        checks=line_group_checks,
        code=package_files("line/pooled.py", "line/check.py"),
    output:
        groups=out("line/{line}/pooled.json"),
    log:
        out("line/{line}/logs/pooled.log"),
    wildcard_constraints:
        line=LINE_NAME,
    conda:
        ENV
    threads: 1
    script:
        "../scripts/line_pooled.py"


rule line_report:
    """The line's page: its pots by how they disagree, each group's outcome, the groups pooled again."""
    input:
        table=out("line/{line}/line.csv"),
        groups=out("line/{line}/groups.json"),
        findings=line_group_findings,
        checks=line_group_checks,
        pooled=out("line/{line}/pooled.json"),
        pooled_findings=line_pooled_findings,
        pooled_checks=line_pooled_checks,
        code=package_files("line"),
    output:
        page=out("line/{line}/line.md"),
    log:
        out("line/{line}/logs/report.log"),
    wildcard_constraints:
        line=LINE_NAME,
    conda:
        ENV
    threads: 1
    params:
        config=lambda wildcards: config,
    script:
        "../scripts/line_report.py"
