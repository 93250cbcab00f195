# clothscope: fabric type and simulation parameters from one photo of cloth.
# This file is the table of contents; each stage's rules live in workflow/rules/.
#
#   synthesize  (optional) re-render the embedded synthetic dataset and check it
#   prepare     decode each photo into a linear working image, or reject it;
#               rejection_report lists every rejected image
#   fit         inverse rendering: fit_geometry -> fit_material -> fit_normals
#   features    Fourier features of each normal map (fitted or truth) -> feature_table
#   classify    QDA: LOOCV reports, model, query predictions, per-image records; feature sets
#               side by side (fitted maps against the photo alone);
#               paper_tables (the paper's 3 experiments) and sweep (settings grid)
#   physics     ArcSim cloth parameters of each image from its class posteriors
from snakemake.utils import min_version

min_version("9.0")


configfile: "config/config.yaml"


include: "workflow/rules/common.smk"
include: "workflow/rules/synthesize.smk"
include: "workflow/rules/prepare.smk"
include: "workflow/rules/fit.smk"
include: "workflow/rules/features.smk"
include: "workflow/rules/classify.smk"
include: "workflow/rules/physics.smk"


rule all:
    default_target: True
    input:
        prepared_images(),
        rejection_report(),
        classify_outputs(config["features"]["normal_source"]),
        feature_set_outputs(),
        physics_outputs(config["features"]["normal_source"]),
        paper_tables_in_all(config["features"]["normal_source"]),
        fit_accuracy_report() if config["features"]["normal_source"] == "fitted" else [],
        diagnosis_outputs(),
