# Re-render the embedded synthetic dataset from its seed and compare it with the
# committed copy (target: check_synthetic), render the held-out set from another seed
# (target: holdout_set, into results/holdout/ with its sample sheet), or render the
# capture-realistic field set (target: field_set, results/field/). Not part of `all`.


from clothscope.synth.field import FIELD_FABRICS, field_index
from clothscope.synth.generate import dataset_index

SYNTHETIC = dataset_index(config["synthesize"]["colors_per_class"])
FIELD = field_index(
    config["synthesize"]["field"]["images_per_class"],
    config["synthesize"]["field"]["classes"],
)


wildcard_constraints:
    fabric="|".join(FIELD_FABRICS),


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
        dataset="synthetic",
    script:
        "../scripts/dataset_sheet.py"


rule synthesize_field:
    output:
        image=os.path.join(RESULTS, "field", "{fabric}", "{image}.jpg"),
        truth=os.path.join(RESULTS, "field", "{fabric}", "{image}.truth.json"),
        normal=os.path.join(RESULTS, "field", "{fabric}", "{image}.truth-normal.png"),
        height=os.path.join(RESULTS, "field", "{fabric}", "{image}.truth-height.png"),
        fold=os.path.join(RESULTS, "field", "{fabric}", "{image}.truth-fold.npy"),
    log:
        os.path.join(RESULTS, "logs", "synthesize_field", "{fabric}", "{image}.log"),
    benchmark:
        os.path.join(
            RESULTS, "benchmarks", "synthesize_field", "{fabric}", "{image}.tsv"
        )
    wildcard_constraints:
        image=r"[a-z_]+_\d\d",
    conda:
        "../../environment.yml"
    threads: 2
    resources:
        mem_mb=6000,
        runtime=15,
        gpu=GPUS,
    params:
        settings=config["synthesize"]["field"],
        variant=config["variant"],
    script:
        "../scripts/synthesize_field.py"


rule field_set:
    input:
        field_outputs(),
    output:
        os.path.join(RESULTS, "field", "samples.tsv"),
    log:
        os.path.join(RESULTS, "logs", "field_set.log"),
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=500,
        runtime=5,
    params:
        seed=config["synthesize"]["field"]["seed"],
        dataset="field",
    script:
        "../scripts/dataset_sheet.py"
