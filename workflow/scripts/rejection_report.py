"""Snakemake job: list rejected images (one line each) and the status of every image."""
from clothscope.core.joblog import job_log
from clothscope.prepare.rejections import write_prepare_reports

with job_log(snakemake.log[0], "rejection_report") as log:
    accepted, rejected = write_prepare_reports(snakemake.input, snakemake.output.rejected, snakemake.output.summary)
    log.info("%d images accepted, %d rejected", accepted, rejected)
