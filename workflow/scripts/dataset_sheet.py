"""Snakemake job: the sample sheet of a rendered synthetic set (held-out or field), paths as rendered (clothscope.synth.sheet)."""
from clothscope.core.joblog import job_log
from clothscope.synth.sheet import dataset_sheet_job

with job_log(snakemake.log[0], snakemake.rule) as log:
    rows = dataset_sheet_job(list(snakemake.input), snakemake.params.dataset, snakemake.params.seed, snakemake.output[0])
    log.info("%d images, seed %d", rows, snakemake.params.seed)
