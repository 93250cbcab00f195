"""Snakemake job: the inverse renderer's accuracy report (logic in clothscope.evaluate)."""
from clothscope.core.joblog import job_log
from clothscope.evaluate.accuracy import write_accuracy_report

with job_log(snakemake.log[0], "fit_accuracy") as log:
    rows = write_accuracy_report(
        photos=snakemake.params.truth,
        normals_dirs=snakemake.input.fits,
        prepared_dirs=snakemake.input.prepared,
        benchmark_root=snakemake.params.benchmarks,
        table=snakemake.output.table,
        summary=snakemake.output.summary,
    )
    log.info("evaluated %d images", rows)
