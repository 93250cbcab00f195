# Stage 6: each image's ArcSim material (config/physics.yaml) from the classifier's
# per-image records: the likeliest class's measured parameters, with the
# posterior-weighted mean and spread; and the table beside the model, for clothscope predict.
# Target: physics_outputs(source).


rule physics:
    input:
        records=reports_path("{source}", RECORDS_FILE),
        physics=config["classify"]["physics"],
    output:
        images=[
            os.path.join(RESULTS, "physics", "{source}", f"{image}.json")
            for image in IMAGE_IDS
        ],
        table=os.path.join(RESULTS, "models", "{source}", MODEL_PHYSICS_FILE),
    log:
        os.path.join(RESULTS, "logs", "physics", "{source}.log"),
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=1000,
        runtime=5,
    params:
        images=IMAGE_IDS,
    script:
        "../scripts/physics.py"
