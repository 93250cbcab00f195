"""Snakemake job: render one synthetic image with ground truth (clothscope.synth.generate)."""
from clothscope.core.joblog import job_log
from clothscope.synth.generate import synthesize_job

with job_log(snakemake.log[0], "synthesize") as log:
    result = synthesize_job(
        snakemake.wildcards.image,
        snakemake.wildcards.fabric,
        snakemake.params.seed,
        snakemake.params.settings,
        snakemake.params.variant,
        snakemake.threads,
        snakemake.output.image,
    )
    log.info("%s rendered in %.2f s with %s", snakemake.wildcards.image, result.truth["provenance"]["render_seconds"],
             result.truth["effects"])
