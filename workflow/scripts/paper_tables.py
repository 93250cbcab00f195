"""Snakemake job: the paper's three experiments, features recomputed from the normal maps (clothscope.classify.paper_tables)."""
from clothscope.classify.paper_tables import paper_tables_job
from clothscope.core.joblog import job_log

with job_log(snakemake.log[0], "paper_tables") as log:
    paper_tables_job(
        snakemake.input.table,
        snakemake.wildcards.source,
        snakemake.params.images,
        snakemake.params.settings,
        snakemake.params.reg,
        snakemake.output.md,
        snakemake.output.csv,
        log,
    )
