"""Snakemake job: true against fitted relief per class (logic in clothscope.features.diagnosis)."""
from clothscope.core.joblog import job_log
from clothscope.features.diagnosis import diagnosis_job
from clothscope.features.structure import StructureSettings

with job_log(snakemake.log[0], "spectra_diagnosis") as log:
    table = diagnosis_job(snakemake.params.images, StructureSettings(**snakemake.params.structure), snakemake.output.md,
                          snakemake.output.csv, snakemake.output.png)
    log.info("%d images compared", len(table))
