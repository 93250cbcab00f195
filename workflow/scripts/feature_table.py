"""Snakemake job: concatenate the one-row feature files into the feature table (no recomputation)."""
import pyarrow.parquet as pq

from clothscope.core.atomic import write_with
from clothscope.core.joblog import job_log
from clothscope.features.table import concat_rows

with job_log(snakemake.log[0], "feature_table") as log:
    table = concat_rows(list(snakemake.input))
    write_with(snakemake.output[0], lambda tmp: pq.write_table(table, tmp))
    statuses = table.column("status").to_pylist()
    log.info("%d rows, %d ok", len(statuses), statuses.count("ok"))
