"""Snakemake job: LOOCV reports, the all-labelled model, query predictions, per-image records (clothscope.classify.job)."""
import os

from clothscope.classify.job import classify_job
from clothscope.classify.loocv import Choice
from clothscope.core.joblog import job_log

tile_paths = {snakemake.wildcards.source: snakemake.input.tiles}
if snakemake.input.get("photo_tiles"):
    tile_paths["photo"] = snakemake.input.photo_tiles

with job_log(snakemake.log[0], "classify") as log:
    classify_job(
        snakemake.input.table,
        snakemake.params.physics,
        snakemake.wildcards.source,
        snakemake.params.reg,
        os.path.dirname(snakemake.output.reports[0]),
        os.path.dirname(snakemake.output.model_arrays),
        log,
        feature_set=snakemake.params.feature_set,
        subspace=snakemake.params.subspace,
        settings=snakemake.params.settings,
        comparison_csv=snakemake.input.get("comparison") or None,
        photo_table_path=snakemake.input.get("photo") or None,
        tile_paths=tile_paths,
        choice=Choice.from_config(snakemake.params.choice),
        prune=snakemake.params.prune,
        test_tiles=snakemake.params.test_tiles == "mean",
    )
