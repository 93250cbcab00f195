"""Snakemake job: the feature sets side by side (logic in clothscope.classify.feature_sets)."""
from clothscope.classify.feature_sets import feature_sets_job
from clothscope.core.joblog import job_log

with job_log(snakemake.log[0], "feature_sets") as log:
    inputs = {name: path for name, path in snakemake.input.items() if name != "prepared"}
    feature_sets_job(
        {source: path for source, path in inputs.items() if not source.endswith("_tiles")},
        snakemake.params.reg,
        snakemake.params.subspace,
        snakemake.params.fitted_set,
        snakemake.output.md,
        snakemake.output.csv,
        log,
        tile_paths={source[: -len("_tiles")]: path for source, path in inputs.items() if source.endswith("_tiles")},
        test_tiles=snakemake.params.test_tiles == "mean",
        prepared_path=snakemake.input.prepared,
    )
