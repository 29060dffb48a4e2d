rule plot_datasets:
    """The training set (blue) and some test trajectories (orange), 8 states and 5 inputs."""
    input:
        train="results/{rep}data/train.parquet",
        test="results/{rep}data/test.parquet",
        code=package_files("plots", "variables.py"),
    output:
        png=report(
            "results/{rep}figures/datasets.png",
            caption="../report/captions/datasets.rst",
            category="Data",
        ),
        pdf="results/{rep}figures/datasets.pdf",
    log:
        "results/{rep}logs/plot_datasets.log",
    benchmark:
        "results/{rep}benchmarks/plot_datasets.tsv"
    conda:
        ENV
    threads: 1
    params:
        test_trajectories=config["figures"]["dataset_test_trajectories"],
    script:
        "../scripts/plot_datasets.py"
