"""Snakemake job: render one capture-realistic field photo with ground truth (clothscope.synth.field)."""
from clothscope.core.joblog import job_log
from clothscope.synth.field import synthesize_field_job

with job_log(snakemake.log[0], "synthesize_field") as log:
    photo = synthesize_field_job(
        snakemake.wildcards.image,
        snakemake.wildcards.fabric,
        snakemake.params.settings,
        snakemake.params.variant,
        snakemake.threads,
        snakemake.output.image,
    )
    draw = photo.truth["draw"]
    log.info("%s rendered in %.2f s: %s, %d px, period %.1f px, %s, %s", snakemake.wildcards.image,
             photo.truth["provenance"]["render_seconds"], draw["capture"], draw["resolution"], draw["period_px"],
             draw["weave_variant"], draw["colour_scheme"])
