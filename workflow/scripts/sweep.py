"""Snakemake job: LOOCV accuracy over a grid of spectrum settings (clothscope.classify.paper_tables)."""
from clothscope.classify.paper_tables import sweep_job
from clothscope.core.joblog import job_log

with job_log(snakemake.log[0], "sweep") as log:
    sweep_job(
        snakemake.input.table,
        snakemake.wildcards.source,
        snakemake.params.images,
        snakemake.params.settings,
        snakemake.params.sweep,
        snakemake.params.reg,
        snakemake.output.csv,
        snakemake.output.png,
        log,
    )
