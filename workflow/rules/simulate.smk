rule simulate:
    """Simulate one data set with the true model (SPEC section 4)."""
    input:
        code=SIMULATION_CODE,
    output:
        data=out("{rep}data/{split}.parquet"),
    log:
        out("{rep}logs/simulate_{split}.log"),
    benchmark:
        out("{rep}benchmarks/simulate_{split}.tsv")
    conda:
        ENV
    threads: 1
    params:
        config=lambda wildcards: {
            key: config[key] for key in ("seed", "physics", "simulation")
        },
        replicate=replicate_index,
    script:
        "../scripts/simulate.py"


rule cell_constants:
    """The cell's constants, derived from physics.cell (or overridden), with units and sources."""
    input:
        code=package_files("physics"),
    output:
        table=out("cell_constants.csv"),
    log:
        out("logs/cell_constants.log"),
    benchmark:
        out("benchmarks/cell_constants.tsv")
    conda:
        ENV
    threads: 1
    params:
        physics=config["physics"],
    script:
        "../scripts/cell_constants.py"
