"""Snakemake job: prepare one image (logic in clothscope.prepare)."""
from clothscope.core.joblog import job_log
from clothscope.features.structure import StructureSettings
from clothscope.prepare.image import PrepareSettings, prepare_image

with job_log(snakemake.log[0], "prepare") as log:
    record = prepare_image(
        snakemake.wildcards.image,
        snakemake.params.path,
        snakemake.output[0],
        PrepareSettings(**snakemake.params.settings),
        StructureSettings(**snakemake.params.lattice),
    )
    log.info("%s: %s %s", record["image_id"], record["status"], record["reason"])
    scale = record.get("scale") or {}
    if scale.get("note"):
        log.info("%s: %s", record["image_id"], scale["note"])
