"""Snakemake job: concatenate the one-row feature files into the feature table, their tiles into the tile table (clothscope.features.table)."""
from clothscope.core.joblog import job_log
from clothscope.features.table import feature_table_job

with job_log(snakemake.log[0], "feature_table") as log:
    statuses = feature_table_job(list(snakemake.input.rows), snakemake.output.table,
                                 list(snakemake.input.tiles), snakemake.output.tiles).column("status").to_pylist()
    log.info("%d rows, %d ok", len(statuses), statuses.count("ok"))
