"""Snakemake job: compare regenerated synthetic images with the committed set (clothscope.synth.verify)."""
from clothscope.core.joblog import job_log
from clothscope.synth.verify import check_job

with job_log(snakemake.log[0], "check_synthetic") as log:
    rows = check_job(snakemake.input.images, snakemake.params.committed, snakemake.output[0])
    failed = [row["image_id"] for row in rows if not row["reproduced"]]
    log.info("%d images compared, %d not reproduced: %s", len(rows), len(failed), ", ".join(failed) or "none")
