"""Snakemake job: the inverse renderer's accuracy report (logic in clothscope.evaluate)."""
import os
from pathlib import Path

from clothscope.core.joblog import job_log
from clothscope.core.truth import truth_paths
from clothscope.evaluate.accuracy import write_accuracy_report

with job_log(snakemake.log[0], "fit_accuracy") as log:
    rows = write_accuracy_report(
        images=snakemake.params.images,
        fit_dirs=[os.path.dirname(d) for d in snakemake.input.fits],
        truth_jsons=[truth_paths(Path(snakemake.params.truth[i]))["json"] for i in snakemake.params.images],
        benchmark_root=snakemake.params.benchmarks,
        table=snakemake.output.table,
        summary=snakemake.output.summary,
        prepared_statuses=[os.path.join(d, "status.json") for d in snakemake.input.prepared],
    )
    log.info("evaluated %d images", rows)
