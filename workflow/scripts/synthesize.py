"""Snakemake job: render one synthetic image with ground truth (logic in clothscope.synth)."""
from clothscope.core.joblog import job_log
from clothscope.synth.generate import DYES, save, synthesize

with job_log(snakemake.log[0], "synthesize") as log:
    settings = snakemake.params.settings
    fabric, image_id = snakemake.wildcards.fabric, snakemake.wildcards.image
    dye = image_id.removeprefix(f"{fabric}_")
    if dye not in DYES:
        raise ValueError(f"image id {image_id!r} must be <class>_<dye> with a dye in {', '.join(DYES)}")
    result = synthesize(
        fabric,
        list(DYES).index(dye),
        snakemake.params.seed,
        settings["resolution"],
        settings["spp"],
        settings["mesh_resolution"],
        snakemake.params.variant,
        snakemake.threads,
    )
    save(result, snakemake.output.image)
    log.info("%s rendered in %.2f s with %s", image_id, result.truth["provenance"]["render_seconds"], result.truth["effects"])
