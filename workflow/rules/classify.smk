# Stage 5: QDA on the feature table. LOOCV reports, the all-labelled model, predictions for
# the query images (empty fabric_class) and per-image ArcSim physics; the paper's three
# experiments and the spectrum-settings sweep (features recomputed from the normal maps).
# Targets without wildcards, for the configured features.normal_source:
#   classify_reports, paper_reports, sweep_reports


rule classify:
    input:
        table=feature_table("{source}"),
        physics=config["classify"]["physics"],
    output:
        reports=[reports_path("{source}", name) for name in CLASSIFY_REPORTS],
        model=os.path.join(RESULTS, "models", "{source}", "qda.pkl"),
        model_meta=os.path.join(RESULTS, "models", "{source}", "qda.pkl.meta.json"),
        physics=[os.path.join(RESULTS, "physics", "{source}", f"{image}.json") for image in IMAGE_IDS],
    params:
        reg=config["classify"]["reg"],
        images=IMAGE_IDS,
    log:
        os.path.join(RESULTS, "logs", "classify", "{source}.log"),
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    conda:
        "../../environment.yml"
    script:
        "../scripts/classify.py"


rule paper_tables:
    input:
        table=feature_table("{source}"),
        normals=all_normal_inputs,
    output:
        md=reports_path("{source}", "paper_tables.md"),
        csv=reports_path("{source}", "paper_tables.csv"),
    params:
        settings=FEATURE_SETTINGS,
        reg=config["classify"]["reg"],
        images=image_sources(),
    log:
        os.path.join(RESULTS, "logs", "paper_tables", "{source}.log"),
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    conda:
        "../../environment.yml"
    script:
        "../scripts/paper_tables.py"


rule sweep:
    input:
        table=feature_table("{source}"),
        normals=all_normal_inputs,
    output:
        csv=reports_path("{source}", "sweep.csv"),
        png=reports_path("{source}", "sweep.png"),
    params:
        settings=FEATURE_SETTINGS,
        sweep=config["classify"]["sweep"],
        reg=config["classify"]["reg"],
        images=image_sources(),
    log:
        os.path.join(RESULTS, "logs", "sweep", "{source}.log"),
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    conda:
        "../../environment.yml"
    script:
        "../scripts/sweep.py"


rule classify_reports:
    input:
        classify_outputs(config["features"]["normal_source"]),
        physics_outputs(config["features"]["normal_source"]),


rule paper_reports:
    input:
        paper_table_outputs(config["features"]["normal_source"]),


rule sweep_reports:
    input:
        sweep_outputs(config["features"]["normal_source"]),
