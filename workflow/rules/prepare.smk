# Stage 0: decode, orient, linearise, crop and resize each photo; mark clipped pixels.
# A bad image is recorded as rejected (status.json) and does not fail the job.


rule prepare:
    input:
        image_path,
    output:
        directory(os.path.join(RESULTS, "prepared", "{image}")),
    log:
        os.path.join(RESULTS, "logs", "prepare", "{image}.log"),
    benchmark:
        os.path.join(RESULTS, "benchmarks", "prepare", "{image}.tsv")
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=prepare_mem_mb,
        runtime=5,
    params:
        path=sheet_path,
        settings=config["prepare"],
        lattice=lattice_settings(),
    script:
        "../scripts/prepare.py"


rule rejection_report:
    input:
        prepared_images(),
    output:
        rejected=report(
            rejection_report(),
            caption="../report/rejected.rst",
            category="Inputs",
        ),
        summary=os.path.join(RESULTS, "reports", "prepared.tsv"),
    log:
        os.path.join(RESULTS, "logs", "rejection_report.log"),
    conda:
        "../../environment.yml"
    threads: 1
    resources:
        mem_mb=500,
        runtime=5,
    script:
        "../scripts/rejection_report.py"
