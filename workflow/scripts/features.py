"""Snakemake job: the feature row and spectrum plot of one image (logic in clothscope.features)."""
from clothscope.core.joblog import job_log
from clothscope.features.table import features_job

with job_log(snakemake.log[0], "features") as log:
    features_job(
        snakemake.wildcards.image,
        snakemake.params.fabric_class,
        snakemake.wildcards.source,
        snakemake.params.path,
        snakemake.input.get("normals") or snakemake.input.get("prepared"),
        snakemake.params.settings,
        snakemake.output.row,
        snakemake.output.plot,
        log,
        tiles_path=snakemake.output.tiles,
        prepared_dir=snakemake.input.get("prepared"),
    )
