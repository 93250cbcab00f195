# Config validation, the sample sheet and the path helpers every stage shares.
import os
import sys

from clothscope.samples import load_sample_sheet
from clothscope.schema import InputError, load_schema, validate
from clothscope.synth.fabrics import FABRICS
from clothscope.synth.generate import dataset_index

SCHEMAS = os.path.join(workflow.basedir, "workflow", "schemas")


def fail(message):
    """Stop before any job runs, with one line on stderr."""
    sys.exit(f"clothscope: error: {message}")


try:
    config.update(validate(config, load_schema(os.path.join(SCHEMAS, "config.schema.yaml")), "config"))
    SAMPLES = load_sample_sheet(config["samples"], os.path.join(SCHEMAS, "samples.schema.yaml"))
except InputError as err:
    fail(err)

RESULTS = config["results"]
IMAGE_IDS = list(SAMPLES["image_id"])
#: rules that can use a GPU ask for one only when the CUDA variant is forced
GPUS = 1 if config["variant"] == "cuda_ad_rgb" else 0
SYNTHETIC = dataset_index(config["synthesize"]["colors_per_class"])


wildcard_constraints:
    image=r"[A-Za-z0-9][A-Za-z0-9_.-]*",
    fabric="|".join(FABRICS),


def image_path(wildcards):
    """Input photo of one sample-sheet row."""
    return SAMPLES.loc[wildcards.image, "path"]


def prepared_images():
    """Prepared folder of every sample-sheet image."""
    return expand(os.path.join(RESULTS, "prepared", "{image}"), image=IMAGE_IDS)


def rejection_report():
    return os.path.join(RESULTS, "reports", "rejected.tsv")


def synthetic_outputs(kind):
    """Regenerated synthetic files of one kind ("image" or "truth") for every default image."""
    suffix = {"image": ".png", "truth": ".truth.json"}[kind]
    return [os.path.join(RESULTS, "synthetic", fabric, f"{image}{suffix}") for fabric, _, image in SYNTHETIC]
