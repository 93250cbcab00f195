# Stages 1-3: inverse rendering of each prepared photo, one cached stage per rule.
# Changing one stage's settings (fit.<stage> in the config) reruns that stage and what follows.


rule fit_geometry:
    input:
        prepared=os.path.join(RESULTS, "prepared", "{image}"),
    output:
        directory(fit_dir("geometry")),
    log:
        os.path.join(RESULTS, "logs", "fit_geometry", "{image}.log"),
    benchmark:
        os.path.join(RESULTS, "benchmarks", "fit_geometry", "{image}.tsv")
    conda:
        "../../environment.yml"
    threads: config["fit"]["threads"]
    resources:
        mem_mb=config["fit"]["mem_mb"],
        runtime=config["fit"]["runtime"],
        gpu=GPUS,
    params:
        settings=config["fit"]["geometry"],
        variant=config["variant"],
        full_effects=config["fit"]["full_effects"],
        sample_seed=config["fit"]["sample_seed"],
    script:
        "../scripts/fit_stage.py"


rule fit_material:
    input:
        prepared=os.path.join(RESULTS, "prepared", "{image}"),
        previous=fit_dir("geometry"),
    output:
        directory(fit_dir("material")),
    log:
        os.path.join(RESULTS, "logs", "fit_material", "{image}.log"),
    benchmark:
        os.path.join(RESULTS, "benchmarks", "fit_material", "{image}.tsv")
    conda:
        "../../environment.yml"
    threads: config["fit"]["threads"]
    resources:
        mem_mb=config["fit"]["mem_mb"],
        runtime=config["fit"]["runtime"],
        gpu=GPUS,
    params:
        settings=config["fit"]["material"],
        variant=config["variant"],
        full_effects=config["fit"]["full_effects"],
        sample_seed=config["fit"]["sample_seed"],
    script:
        "../scripts/fit_stage.py"


rule fit_normals:
    input:
        prepared=os.path.join(RESULTS, "prepared", "{image}"),
        previous=fit_dir("material"),
    output:
        report(
            directory(fit_dir("normals")),
            patterns=["{name}.png"],
            caption="../report/fit_normals.rst",
            category="Inverse rendering",
            subcategory="{image}",
        ),
    log:
        os.path.join(RESULTS, "logs", "fit_normals", "{image}.log"),
    benchmark:
        os.path.join(RESULTS, "benchmarks", "fit_normals", "{image}.tsv")
    conda:
        "../../environment.yml"
    threads: config["fit"]["threads"]
    resources:
        mem_mb=config["fit"]["mem_mb"],
        runtime=config["fit"]["runtime"],
        gpu=GPUS,
    params:
        settings=config["fit"]["normals"],
        variant=config["variant"],
        full_effects=config["fit"]["full_effects"],
        sample_seed=config["fit"]["sample_seed"],
    script:
        "../scripts/fit_stage.py"


rule fit_accuracy:
    input:
        fits=expand(fit_dir("normals"), image=images_with_truth()),
        prepared=expand(
            os.path.join(RESULTS, "prepared", "{image}"), image=images_with_truth()
        ),
    output:
        table=os.path.join(RESULTS, "reports", "fit_accuracy.csv"),
        summary=report(
            os.path.join(RESULTS, "reports", "fit_accuracy.md"),
            caption="../report/fit_accuracy.rst",
            category="Inverse rendering",
        ),
    log:
        os.path.join(RESULTS, "logs", "fit_accuracy.log"),
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    params:
        truth={i: str(SAMPLES.loc[i, "path"]) for i in images_with_truth()},
        benchmarks=os.path.join(RESULTS, "benchmarks"),
    script:
        "../scripts/fit_accuracy.py"
