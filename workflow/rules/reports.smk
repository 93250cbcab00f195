# Run-level reports.


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
