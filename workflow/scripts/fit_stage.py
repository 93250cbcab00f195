"""Snakemake job: one inverse-rendering stage of one image (logic in clothscope.fit)."""
from clothscope.core.joblog import job_log
from clothscope.fit import jobs
from clothscope.fit.geometry import GeometrySettings
from clothscope.fit.material import MaterialSettings
from clothscope.fit.normals import NormalSettings

stage = snakemake.rule.removeprefix("fit_")
common = dict(variant=snakemake.params.variant, threads=snakemake.threads, full_effects=snakemake.params.full_effects,
              sample_seed=snakemake.params.sample_seed)
with job_log(snakemake.log[0], snakemake.rule) as log:
    inputs, out = snakemake.input, snakemake.output[0]
    if stage == "geometry":
        record = jobs.geometry_job(inputs.prepared, out, GeometrySettings(**snakemake.params.settings), log=log, **common)
    elif stage == "material":
        record = jobs.material_job(inputs.prepared, inputs.previous, out, MaterialSettings(**snakemake.params.settings), log=log, **common)
    else:
        record = jobs.normals_job(inputs.prepared, inputs.previous, out, NormalSettings(**snakemake.params.settings), log=log, **common)
    log.info("%s %s: %s in %.1f s", snakemake.wildcards.image, stage, record["status"], record["seconds"])
