# clothscope: fabric type and simulation parameters from one photo of cloth.
# This file is the table of contents; each stage's rules live in workflow/rules/.
#
#   synthesize  (optional) re-render the embedded synthetic dataset and check it
#   prepare     decode each photo into a linear working image, or reject it
#   reports     list every rejected image
from snakemake.utils import min_version

min_version("9.0")


configfile: "config/config.yaml"


include: "workflow/rules/common.smk"
include: "workflow/rules/synthesize.smk"
include: "workflow/rules/prepare.smk"
include: "workflow/rules/reports.smk"


rule all:
    input:
        prepared_images(),
        rejection_report(),
    default_target: True
