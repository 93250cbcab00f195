"""Snakemake job: each image's ArcSim material from the classifier's records (clothscope.physics.job)."""
from clothscope.core.joblog import job_log
from clothscope.physics.job import physics_job

with job_log(snakemake.log[0], "physics") as log:
    physics_job(
        snakemake.input.records,
        snakemake.input.physics,
        dict(zip(snakemake.params.images, snakemake.output.images)),
        log,
        table_copy=snakemake.output.table,
    )
