# Stage 5: QDA on the feature table. LOOCV reports, the all-labelled model, predictions for
# the query images (empty fabric_class) and each image's record (physics.smk reads it); the feature sets side
# by side (fitted maps, the photo alone, the ground truth); the paper's three experiments
# and the spectrum-settings sweep (features recomputed from the normal maps).
# Targets without wildcards, for the configured features.normal_source:
#   classify_reports, paper_reports, sweep_reports


rule classify:
    input:
        table=feature_table("{source}"),
        comparison=feature_set_comparison,
        photo=lambda wildcards: (
            [] if wildcards.source == "photo" else feature_table("photo")
        ),
        tiles=tile_table("{source}"),
        photo_tiles=lambda wildcards: (
            [] if wildcards.source == "photo" else tile_table("photo")
        ),
    output:
        reports=[classify_report(name) for name in REPORT_FILES],
        model_arrays=os.path.join(RESULTS, "models", "{source}", "model.npz"),
        model_record=os.path.join(RESULTS, "models", "{source}", "model.json"),
        records=reports_path("{source}", RECORDS_FILE),
    log:
        os.path.join(RESULTS, "logs", "classify", "{source}.log"),
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    params:
        reg=config["classify"]["reg"],
        subspace=config["classify"]["subspace"],
        physics=config["classify"]["physics"],
        feature_set=config["classify"]["feature_set"],
        choice=config["classify"]["choice"],
        prune=config["classify"]["prune"],
        test_tiles=config["classify"]["test_tiles"],
        settings={key: config[key] for key in ("prepare", "fit", "features", "variant")},
    script:
        "../scripts/classify.py"


rule feature_sets:
    input:
        **{source: feature_table(source) for source in report_sources()},
        **{f"{source}_tiles": tile_table(source) for source in report_sources()},
        prepared=os.path.join(RESULTS, "reports", "prepared.tsv"),
    output:
        md=report(
            feature_set_outputs()[0],
            caption="../report/feature_sets.rst",
            category="Classifier",
        ),
        csv=feature_set_outputs()[1],
    log:
        os.path.join(RESULTS, "logs", "feature_sets.log"),
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    params:
        reg=config["classify"]["reg"],
        subspace=config["classify"]["subspace"],
        test_tiles=config["classify"]["test_tiles"],
        fitted_set=headline_set(config["features"]["normal_source"]),
    script:
        "../scripts/feature_sets.py"


rule paper_tables:
    input:
        table=feature_table("{source}"),
        normals=all_normal_inputs,
    output:
        md=reports_path("{source}", "paper_tables.md"),
        csv=reports_path("{source}", "paper_tables.csv"),
    log:
        os.path.join(RESULTS, "logs", "paper_tables", "{source}.log"),
    wildcard_constraints:
        source="truth|fitted",
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    params:
        settings=FEATURE_SETTINGS,
        reg=config["classify"]["reg"],
        images=image_sources(),
    script:
        "../scripts/paper_tables.py"


rule sweep:
    input:
        table=feature_table("{source}"),
        normals=all_normal_inputs,
    output:
        csv=reports_path("{source}", "sweep.csv"),
        png=reports_path("{source}", "sweep.png"),
    log:
        os.path.join(RESULTS, "logs", "sweep", "{source}.log"),
    wildcard_constraints:
        source="truth|fitted",
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    params:
        settings=FEATURE_SETTINGS,
        sweep=config["classify"]["sweep"],
        reg=config["classify"]["reg"],
        images=image_sources(),
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


rule spectra_diagnosis:
    input:
        normals=[fit_normals_dir(image) for image in images_with_truth()],
        prepared=[
            os.path.join(RESULTS, "prepared", image) for image in images_with_truth()
        ],
    output:
        md=report(
            os.path.join(RESULTS, "reports", "diagnosis", "spectra.md"),
            caption="../report/spectra_diagnosis.rst",
            category="Classifier",
        ),
        csv=os.path.join(RESULTS, "reports", "diagnosis", "spectra.csv"),
        png=report(
            os.path.join(RESULTS, "reports", "diagnosis", "spectra.png"),
            caption="../report/spectra_diagnosis.rst",
            category="Classifier",
        ),
    log:
        os.path.join(RESULTS, "logs", "spectra_diagnosis.log"),
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    params:
        images=diagnosis_images(),
        structure=config["features"]["structure"],
    script:
        "../scripts/spectra_diagnosis.py"
