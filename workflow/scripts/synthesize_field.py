"""Snakemake job: render one capture-realistic field photo with ground truth (logic in clothscope.synth.field)."""
from clothscope.core.joblog import job_log
from clothscope.synth.field import save_field, synthesize_field

with job_log(snakemake.log[0], "synthesize_field") as log:
    settings = snakemake.params.settings
    fabric, image_id = snakemake.wildcards.fabric, snakemake.wildcards.image
    number = image_id.removeprefix(f"{fabric}_")
    if not number.isdigit():
        raise ValueError(f"image id {image_id!r} must be <class>_<two-digit number>")
    photo = synthesize_field(fabric, int(number), settings["seed"], settings["spp"], settings["max_mesh_resolution"],
                             snakemake.params.variant, snakemake.threads)
    save_field(photo, snakemake.output.image)
    draw = photo.truth["draw"]
    log.info("%s rendered in %.2f s: %s, %d px, period %.1f px, %s, %s", image_id, photo.truth["provenance"]["render_seconds"],
             draw["capture"], draw["resolution"], draw["period_px"], draw["weave_variant"], draw["colour_scheme"])
