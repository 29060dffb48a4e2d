rule train:
    """Train the instances of one model type as one stacked ensemble (docs/model.md §5)."""
    input:
        train=out("{rep}data/train.parquet"),
        code=TRAINING_CODE,
    output:
        models=expand(
            out("{{rep}}models/{{model_type}}/instance{i}.pt"),
            i=range(config["training"]["instances"]),
        ),
        losses=out("{rep}models/{model_type}/losses.parquet"),
        sparsity=out("{rep}models/{model_type}/sparsity.parquet"),
    log:
        out("{rep}logs/train_{model_type}.log"),
    benchmark:
        out("{rep}benchmarks/train_{model_type}.tsv")
    priority: 10  # the longest chain (training, then rollouts): start it first
    conda:
        ENV
    threads: 1
    resources:
        mem_mb=2000,
    params:
        config=lambda wildcards: training_config(wildcards.model_type),
        replicate=replicate_index,
    script:
        "../scripts/train.py"
