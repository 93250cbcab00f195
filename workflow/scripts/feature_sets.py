"""Snakemake job: the feature sets side by side (logic in clothscope.classify.feature_sets)."""
from clothscope.classify.feature_sets import feature_sets_job
from clothscope.core.joblog import job_log

with job_log(snakemake.log[0], "feature_sets") as log:
    feature_sets_job(
        dict(snakemake.input.items()),
        snakemake.params.reg,
        snakemake.params.subspace,
        snakemake.params.fitted_set,
        snakemake.output.md,
        snakemake.output.csv,
        log,
    )
