# Config validation, the sample sheet and the path helpers every stage shares.
import os
import sys

from clothscope.classify.outputs import (
    IN_SNAKEMAKE_REPORT,
    MODEL_PHYSICS_FILE,
    RECORDS_FILE,
    REPORT_FILES,
)
from clothscope.core.config import (
    SCHEMA_PATH,
    check_sample_counts,
    check_threads_across,
)
from clothscope.core.imageio import file_problem
from clothscope.core.samples import SAMPLES_SCHEMA_PATH, load_sample_sheet
from clothscope.core.scheduler import keep_one_scheduler_wakeup
from clothscope.core.schema import InputError, apply_preset, load_schema, validate
from clothscope.prepare.image import prepare_memory_mb

PRESETS = os.path.join(workflow.basedir, "config", "presets")


def fail(message):
    """Stop before any job runs, with one line on stderr."""
    sys.exit(f"clothscope: error: {message}")


try:
    config.update(apply_preset(config, PRESETS))
    config.update(validate(config, load_schema(SCHEMA_PATH), "config"))
    check_sample_counts(config)
    check_threads_across(config)
    SAMPLES = load_sample_sheet(config["samples"], SAMPLES_SCHEMA_PATH)
except InputError as err:
    fail(err)

# Snakemake 9 adds an endless one-second wake-up chain to its scheduler on every job event
# (clothscope/core/scheduler.py); keep one pending wake-up so the jobs keep the CPU.
keep_one_scheduler_wakeup()

RESULTS = config["results"]
IMAGE_IDS = list(SAMPLES["image_id"])
#: rules that can use a GPU ask for one only when the CUDA variant is forced
GPUS = 1 if config["variant"] == "cuda_ad_rgb" else 0


wildcard_constraints:
    image=r"[A-Za-z0-9][A-Za-z0-9_.-]*",


def image_path(wildcards):
    """Input photo of one sample-sheet row; none when it is not a readable file (prepare then rejects the image, saying why)."""
    path = SAMPLES.loc[wildcards.image, "path"]
    return [] if file_problem(path) else path


def prepare_mem_mb(wildcards):
    """The prepare job's memory request: grows with the photo's pixel count (clothscope.prepare.image.prepare_memory_mb)."""
    return prepare_memory_mb(sheet_path(wildcards), config["prepare"]["max_megapixels"])


def sheet_path(wildcards):
    """The path a sample-sheet row names, readable or not."""
    return SAMPLES.loc[wildcards.image, "path"]


def prepared_images():
    """Prepared folder of every sample-sheet image."""
    return expand(os.path.join(RESULTS, "prepared", "{image}"), image=IMAGE_IDS)


def rejection_report():
    return os.path.join(RESULTS, "reports", "rejected.tsv")


# Synthetic-set outputs (SYNTHETIC and FIELD are built in workflow/rules/synthesize.smk)
def synthetic_outputs(kind, dataset="synthetic"):
    """Rendered synthetic files of one kind ("image" or "truth") for every default image of a dataset."""
    suffix = {"image": ".png", "truth": ".truth.json"}[kind]
    return [
        os.path.join(RESULTS, dataset, fabric, f"{image}{suffix}")
        for fabric, _, image in SYNTHETIC
    ]


def field_outputs():
    """Every photo of the capture-realistic field set (rule synthesize_field)."""
    return [
        os.path.join(RESULTS, "field", fabric, f"{image}.jpg")
        for fabric, _, image in FIELD
    ]


# --- features and classifier (workflow/rules/features.smk, classify.smk) ---
# {source} is the normal source: "fitted" (rule fit_normals) or "truth" (synthetic ground truth).
from pathlib import Path

from clothscope.features.sources import NORMAL_SOURCES
from clothscope.features.table import row_settings
from clothscope.classify.feature_sets import headline_set
from clothscope.classify.paper_tables import PAPER_EXPERIMENTS
from clothscope.core.truth import truth_paths


wildcard_constraints:
    source="|".join(NORMAL_SOURCES),


if "table" in IMAGE_IDS:
    fail(
        f"{config['samples']}: image_id 'table' is reserved (results/features/<source>/table.parquet); rename it"
    )

#: feature settings a row depends on (normal_source only picks the source that `all` builds)
FEATURE_SETTINGS = row_settings(config["features"])


def source_feature_settings(wildcards):
    """The feature settings a row of {source} depends on (fitted_field only for fitted rows)."""
    return row_settings(config["features"], wildcards.source)


def lattice_settings():
    """The structure settings prepare's lattice test reads. Prepare takes no LBP histograms, so ``lbp_scale`` is held
    at one value: changing it re-describes the maps without re-preparing (and so refitting) every photo.
    """
    return {**config["features"]["structure"], "lbp_scale": "pixels"}


def features_path(source, name):
    return os.path.join(RESULTS, "features", source, name)


def fit_normals_dir(image):
    return os.path.join(RESULTS, "fit", image, "normals")


def normal_source_inputs(source, image):
    """Files one image's features come from: its fit_normals folder and prepared photo, its prepared photo, or its
    image, ground truth and prepared photo (whose crop and scale the true maps are put in).
    """
    if source == "fitted":
        return {
            "normals": fit_normals_dir(image),
            "prepared": os.path.join(RESULTS, "prepared", image),
        }
    if source == "photo":
        return {"prepared": os.path.join(RESULTS, "prepared", image)}
    path = SAMPLES.loc[image, "path"]
    truth = truth_paths(Path(path))
    return {
        "image": path,
        "prepared": os.path.join(RESULTS, "prepared", image),
        **{
            key: str(truth[key])
            for key in ("normal", "height", "json")
            if truth[key].is_file()
        },
    }


def feature_inputs(wildcards):
    if (
        wildcards.image not in SAMPLES.index
    ):  # e.g. "table": rule feature_table makes that file
        return {}
    return normal_source_inputs(wildcards.source, wildcards.image)


def all_normal_inputs(wildcards):
    """Every image's normal-source files (paper tables and sweep recompute features from them)."""
    return [
        f
        for image in IMAGE_IDS
        for f in normal_source_inputs(wildcards.source, image).values()
    ]


def image_sources():
    """Image id to its sheet path, fit_normals folder and prepared folder (params of the table rules)."""
    return {
        image: {
            "path": SAMPLES.loc[image, "path"],
            "fit_dir": fit_normals_dir(image),
            "prepared_dir": os.path.join(RESULTS, "prepared", image),
        }
        for image in IMAGE_IDS
    }


def feature_rows(wildcards):
    return [features_path(wildcards.source, f"{image}.parquet") for image in IMAGE_IDS]


def feature_table(source):
    return features_path(source, "table.parquet")


def tile_rows(wildcards):
    return [
        features_path(wildcards.source, os.path.join("tiles", f"{image}.parquet"))
        for image in IMAGE_IDS
    ]


def tile_table(source):
    """Every image's tile rows (features.tiles): extra training rows for the classifier."""
    return features_path(source, os.path.join("tiles", "table.parquet"))


def reports_path(source, name):
    return os.path.join(RESULTS, "reports", source, name)


def classify_report(name):
    """One output of the classify rule, marked for the Snakemake report when it is one of IN_SNAKEMAKE_REPORT."""
    path = reports_path("{source}", name)
    if name not in IN_SNAKEMAKE_REPORT:
        return path
    return report(
        path,
        caption="../report/classify.rst",
        category="Classifier",
        subcategory="{source} maps",
        labels={"source": "{source}", "file": name},
    )


def classify_outputs(source):
    return [reports_path(source, name) for name in REPORT_FILES]


def report_sources():
    """Sources the feature-set report compares: the configured one, the photo alone, and the ground truth if any."""
    main = config["features"]["normal_source"]
    sources = [main] + ([] if main == "photo" else ["photo"])
    if main != "truth" and images_with_truth():
        sources.append("truth")
    return sources


def feature_set_outputs():
    return [
        os.path.join(RESULTS, "reports", f"feature_sets.{ext}") for ext in ("md", "csv")
    ]


def feature_set_comparison(wildcards):
    """The feature-set CSV, for the classifier of the configured source (its summary line)."""
    return (
        feature_set_outputs()[1]
        if wildcards.source == config["features"]["normal_source"]
        else []
    )


def physics_outputs(source):
    return [
        os.path.join(RESULTS, "physics", source, f"{image}.json") for image in IMAGE_IDS
    ] + [os.path.join(RESULTS, "models", source, MODEL_PHYSICS_FILE)]


def paper_table_outputs(source):
    return [
        reports_path(source, "paper_tables.md"),
        reports_path(source, "paper_tables.csv"),
    ]


def paper_tables_in_all(source):
    """The paper tables, for `all` only when the sheet labels every class of the paper's first experiment."""
    labelled = set(SAMPLES["fabric_class"].fillna("").astype(str))
    return (
        paper_table_outputs(source)
        if set(PAPER_EXPERIMENTS[0].classes) <= labelled
        else []
    )


def sweep_outputs(source):
    return [reports_path(source, "sweep.csv"), reports_path(source, "sweep.png")]


def fit_dir(stage):
    return os.path.join(RESULTS, "fit", "{image}", stage)


def images_with_truth():
    """Sample-sheet images that carry synthetic ground truth (the accuracy report needs it)."""
    return [
        i
        for i in IMAGE_IDS
        if truth_paths(Path(SAMPLES.loc[i, "path"]))["json"].exists()
    ]


def diagnosis_images():
    """Images with ground truth: their class, photo path and fit_normals folder (params of spectra_diagnosis)."""
    return {
        i: {
            "fabric_class": SAMPLES.loc[i, "fabric_class"],
            "path": SAMPLES.loc[i, "path"],
            "fit_dir": fit_normals_dir(i),
            "prepared_dir": os.path.join(RESULTS, "prepared", i),
        }
        for i in images_with_truth()
    }


def diagnosis_outputs():
    """The true-against-fitted spectra report, when the sheet has images with ground truth and the source is fitted."""
    if config["features"]["normal_source"] != "fitted" or not images_with_truth():
        return []
    return [
        os.path.join(RESULTS, "reports", "diagnosis", f"spectra.{ext}")
        for ext in ("md", "csv", "png")
    ]


def fit_accuracy_report():
    """The inverse renderer's accuracy report, when the sheet has images with ground truth."""
    return (
        [os.path.join(RESULTS, "reports", "fit_accuracy.md")]
        if images_with_truth()
        else []
    )
