rule plot_datasets:
    """The training set (blue) and some test trajectories (orange), 8 states and 5 inputs."""
    input:
        train=out("{rep}data/train.parquet"),
        test=out("{rep}data/test.parquet"),
        code=package_files("plots", "variables.py"),
    output:
        png=report(
            out("{rep}figures/datasets.png"),
            caption="../report/captions/datasets.rst",
            category="Data",
        ),
        pdf=out("{rep}figures/datasets.pdf"),
    log:
        out("{rep}logs/plot_datasets.log"),
    benchmark:
        out("{rep}benchmarks/plot_datasets.tsv")
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
            out("{{rep}}models/{model_type}/losses.parquet"), model_type=MODEL_TYPES
        ),
        code=package_files("plots"),
    output:
        png=report(
            out("{rep}figures/training_curves.png"),
            caption="../report/captions/training_curves.rst",
            category="Training",
        ),
        pdf=out("{rep}figures/training_curves.pdf"),
    log:
        out("{rep}logs/plot_training_curves.log"),
    benchmark:
        out("{rep}benchmarks/plot_training_curves.tsv")
    conda:
        ENV
    threads: 1
    script:
        "../scripts/plot_training_curves.py"


rule plot_results:
    """The paper's violin and blow-up figures (coded metric; the printed one alongside)."""
    input:
        metrics=out("{rep}eval/metrics.parquet"),
        code=package_files("plots"),
    output:
        violin=report(
            out("{rep}figures/error_violins.png"),
            caption="../report/captions/error_violins.rst",
            category="Results",
        ),
        violin_pdf=out("{rep}figures/error_violins.pdf"),
        blowups=report(
            out("{rep}figures/blowups.png"),
            caption="../report/captions/blowups.rst",
            category="Results",
        ),
        blowups_pdf=out("{rep}figures/blowups.pdf"),
        violin_printed=out("{rep}figures/error_violins_printed.png"),
        blowups_printed=out("{rep}figures/blowups_printed.png"),
    log:
        out("{rep}logs/plot_results.log"),
    benchmark:
        out("{rep}benchmarks/plot_results.tsv")
    conda:
        ENV
    threads: 1
    script:
        "../scripts/plot_results.py"


rule plot_rolling_forecast:
    """Truth, PBM and the mean and 99.7 % band of the chosen network types on one test trajectory."""
    input:
        test=out("{rep}data/test.parquet"),
        forecasts=expand(
            out("{{rep}}eval/{model}/forecasts.parquet"),
            model=[*config["figures"]["rolling_forecast_types"], "pbm", *DISCOVERED],
        ),
        code=package_files("plots"),
    output:
        png=report(
            out("{rep}figures/rolling_forecast.png"),
            caption="../report/captions/rolling_forecast.rst",
            category="Results",
        ),
        pdf=out("{rep}figures/rolling_forecast.pdf"),
    log:
        out("{rep}logs/plot_rolling_forecast.log"),
    benchmark:
        out("{rep}benchmarks/plot_rolling_forecast.tsv")
    conda:
        ENV
    threads: 1
    params:
        trajectory=config["figures"]["rolling_forecast_trajectory"],
        types=config["figures"]["rolling_forecast_types"],
        physics=["pbm", *DISCOVERED],
        liquidus=config["physics"]["ablated_liquidus_temperature"],
    script:
        "../scripts/plot_rolling_forecast.py"
