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


rule plot_training_curves:
    """Per-epoch training loss of every instance of every model type."""
    input:
        losses=expand(
            "results/{{rep}}models/{model_type}/losses.parquet", model_type=MODEL_TYPES
        ),
        code=package_files("plots"),
    output:
        png=report(
            "results/{rep}figures/training_curves.png",
            caption="../report/captions/training_curves.rst",
            category="Training",
        ),
        pdf="results/{rep}figures/training_curves.pdf",
    log:
        "results/{rep}logs/plot_training_curves.log",
    benchmark:
        "results/{rep}benchmarks/plot_training_curves.tsv"
    conda:
        ENV
    threads: 1
    script:
        "../scripts/plot_training_curves.py"
