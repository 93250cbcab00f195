# Re-render the embedded synthetic dataset from its seed and compare it with the
# committed copy (target: check_synthetic), or render the held-out set from another seed
# (target: holdout_set, into results/holdout/ with its sample sheet). Not part of `all`.


rule synthesize:
    output:
        image=os.path.join(RESULTS, "{dataset}", "{fabric}", "{image}.png"),
        truth=os.path.join(RESULTS, "{dataset}", "{fabric}", "{image}.truth.json"),
        normal=os.path.join(
            RESULTS, "{dataset}", "{fabric}", "{image}.truth-normal.png"
        ),
        height=os.path.join(
            RESULTS, "{dataset}", "{fabric}", "{image}.truth-height.png"
        ),
        fold=os.path.join(RESULTS, "{dataset}", "{fabric}", "{image}.truth-fold.npy"),
    log:
        os.path.join(
            RESULTS, "logs", "synthesize", "{dataset}", "{fabric}", "{image}.log"
        ),
    benchmark:
        os.path.join(
            RESULTS, "benchmarks", "synthesize", "{dataset}", "{fabric}", "{image}.tsv"
        )
    wildcard_constraints:
        dataset="synthetic|holdout",
    conda:
        "../../environment.yml"
    threads: 2
    resources:
        mem_mb=3000,
        runtime=10,
        gpu=GPUS,
    params:
        settings=config["synthesize"],
        seed=lambda wildcards: config["synthesize"][
            "seed" if wildcards.dataset == "synthetic" else "holdout_seed"
        ],
        variant=config["variant"],
    script:
        "../scripts/synthesize.py"


rule check_synthetic:
    input:
        images=synthetic_outputs("image"),
        truths=synthetic_outputs("truth"),
    output:
        report(
            os.path.join(RESULTS, "reports", "synthetic_check.tsv"),
            caption="../report/synthetic_check.rst",
            category="Synthetic data",
        ),
    log:
        os.path.join(RESULTS, "logs", "check_synthetic.log"),
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    params:
        committed=config["synthesize"]["committed"],
    script:
        "../scripts/check_synthetic.py"


rule holdout_set:
    input:
        synthetic_outputs("image", "holdout"),
    output:
        os.path.join(RESULTS, "holdout", "samples.tsv"),
    log:
        os.path.join(RESULTS, "logs", "holdout_set.log"),
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=500,
        runtime=5,
    params:
        seed=config["synthesize"]["holdout_seed"],
    script:
        "../scripts/holdout_sheet.py"
