# Re-render the embedded synthetic dataset from its seed and compare it with the
# committed copy (target: check_synthetic). Not part of `all`: data/ already holds it.


rule synthesize:
    output:
        image=os.path.join(RESULTS, "synthetic", "{fabric}", "{image}.png"),
        truth=os.path.join(RESULTS, "synthetic", "{fabric}", "{image}.truth.json"),
        normal=os.path.join(RESULTS, "synthetic", "{fabric}", "{image}.truth-normal.png"),
        height=os.path.join(RESULTS, "synthetic", "{fabric}", "{image}.truth-height.png"),
        fold=os.path.join(RESULTS, "synthetic", "{fabric}", "{image}.truth-fold.npy"),
    params:
        settings=config["synthesize"],
        variant=config["variant"],
    log:
        os.path.join(RESULTS, "logs", "synthesize", "{fabric}", "{image}.log"),
    benchmark:
        os.path.join(RESULTS, "benchmarks", "synthesize", "{fabric}", "{image}.tsv")
    threads: 2
    resources:
        mem_mb=3000,
        runtime=10,
        gpu=GPUS,
    conda:
        "../../environment.yml"
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
    params:
        committed=config["synthesize"]["committed"],
    log:
        os.path.join(RESULTS, "logs", "check_synthetic.log"),
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    conda:
        "../../environment.yml"
    script:
        "../scripts/check_synthetic.py"
