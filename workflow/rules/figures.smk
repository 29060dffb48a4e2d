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


rule plot_results:
    """The paper's violin and blow-up figures (coded metric; the printed one alongside)."""
    input:
        metrics="results/{rep}eval/metrics.parquet",
        code=package_files("plots"),
    output:
        violin=report(
            "results/{rep}figures/error_violins.png",
            caption="../report/captions/error_violins.rst",
            category="Results",
        ),
        violin_pdf="results/{rep}figures/error_violins.pdf",
        blowups=report(
            "results/{rep}figures/blowups.png",
            caption="../report/captions/blowups.rst",
            category="Results",
        ),
        blowups_pdf="results/{rep}figures/blowups.pdf",
        violin_printed="results/{rep}figures/error_violins_printed.png",
        blowups_printed="results/{rep}figures/blowups_printed.png",
    log:
        "results/{rep}logs/plot_results.log",
    benchmark:
        "results/{rep}benchmarks/plot_results.tsv"
    conda:
        ENV
    threads: 1
    script:
        "../scripts/plot_results.py"


rule plot_rolling_forecast:
    """Truth, PBM and the mean and 99.7 % band of the chosen network types on one test trajectory."""
    input:
        test="results/{rep}data/test.parquet",
        forecasts=expand(
            "results/{{rep}}eval/{model}/forecasts.parquet",
            model=[*config["figures"]["rolling_forecast_types"], "pbm"],
        ),
        code=package_files("plots"),
    output:
        png=report(
            "results/{rep}figures/rolling_forecast.png",
            caption="../report/captions/rolling_forecast.rst",
            category="Results",
        ),
        pdf="results/{rep}figures/rolling_forecast.pdf",
    log:
        "results/{rep}logs/plot_rolling_forecast.log",
    benchmark:
        "results/{rep}benchmarks/plot_rolling_forecast.tsv"
    conda:
        ENV
    threads: 1
    params:
        trajectory=config["figures"]["rolling_forecast_trajectory"],
        types=config["figures"]["rolling_forecast_types"],
        liquidus=config["physics"]["ablated_liquidus_temperature"],
    script:
        "../scripts/plot_rolling_forecast.py"
