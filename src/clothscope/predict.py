"""``clothscope predict``: fabric class and physics of photos, with a model the workflow trained.

Each photo goes through the workflow's own stage functions in this process:
prepare, the three fit stages (when the model reads fitted-map features, or
with ``render``), the feature rows of the sources the model reads, the model's
posteriors and the ArcSim physics. The settings are the ones the model was
trained with (its record), so a photo's features are computed the way the
training images' were.
"""
from __future__ import annotations

import logging
import os
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from clothscope.classify.feature_sets import joined_table, joined_tiles
from clothscope.classify.model import VotingModel, predict
from clothscope.classify.outputs import MODEL_PHYSICS_FILE
from clothscope.classify.rows import posterior_column
from clothscope.core.atomic import write_json
from clothscope.core.config import schema_defaults
from clothscope.core.schema import deep_merge
from clothscope.features.sources import STATUS_OK
from clothscope.features.structure import StructureSettings
from clothscope.features.table import features_job
from clothscope.fit import jobs
from clothscope.fit.geometry import GeometrySettings
from clothscope.fit.material import MaterialSettings
from clothscope.fit.normals import NormalSettings
from clothscope.physics.materials import PhysicsEntry, load_physics_table, physics_for
from clothscope.prepare.image import PrepareSettings, prepare_image

#: Stages of one photo, in order (the progress bar counts them).
STAGES = ("prepare", "fit_geometry", "fit_material", "fit_normals", "features", "classify")


@dataclass
class Prediction:
    """What ``predict`` found for one photo: a class, or the reason there is none."""

    photo: str
    image_id: str
    predicted_class: str | None
    posterior: float | None
    physics_path: str | None
    reason: str = ""
    note: str = ""  # prepare's note on the thread scale (threads too fine or too coarse, no lattice), or ""


def model_sources(model: VotingModel) -> list[str]:
    """Feature sources the model's columns (``<source>.<column>``) come from, its own normal source first."""
    own = str(model.metadata.get("metadata", {}).get("normal_source", ""))
    prefixes = sorted({c.split(".", 1)[0] for c in model.feature_columns})
    return sorted(prefixes, key=lambda source: source != own)


#: What models recorded before a key existed were processed with, where it differs from the schema default.
LEGACY = {"prepare": {"scale": "frame"}, "fit": {"normals": {"colour_model": "one_colour", "layout_mixing": "hard"}},
          "features": {"fitted_field": "relief", "period_source": "field"}}


def model_physics_table(model: VotingModel, folder: str | os.PathLike[str],
                        override: str | None = None) -> dict[str, PhysicsEntry]:
    """The class -> ArcSim table of a prediction: ``override`` (a YAML path), else the copy beside the model.

    The ``physics`` rule keeps that copy in the model's folder (:data:`MODEL_PHYSICS_FILE`). A folder without one
    (made before the copy existed) is read from the YAML path its record names.

    Raises
    ------
    ValueError
        One line naming the table, or saying to pass ``--physics`` when neither the copy nor the path is found.
    """
    if override:
        return load_physics_table(override)
    copy = Path(folder) / MODEL_PHYSICS_FILE
    if copy.is_file():
        return load_physics_table(copy)  # JSON is YAML; the reader ignores the copy's "from"
    recorded = model.metadata.get("metadata", {}).get("physics_table") or "config/physics.yaml"
    if not Path(recorded).is_file():
        raise ValueError(f"{copy}: does not exist, and the physics table the model names ({recorded}) is not found from "
                         "here; pass --physics YAML, or rerun the workflow's physics rule")
    return load_physics_table(recorded)


def scored_with_tiles(model: VotingModel) -> bool:
    """Whether the model scores an image with its tiles (``classify.test_tiles: mean``; older records: no)."""
    return model.metadata.get("metadata", {}).get("test_tiles", "none") == "mean"


def training_settings(model: VotingModel) -> dict[str, Any]:
    """The prepare, fit and features settings (and Mitsuba variant) the model's training images were processed with.

    A key the record lacks (it predates the key) takes its :data:`LEGACY` value, else its schema default.
    """
    settings = model.metadata.get("metadata", {}).get("settings")
    if not isinstance(settings, dict) or not {"prepare", "fit", "features", "variant"} <= set(settings):
        raise ValueError("model record lacks the settings its images were processed with; retrain it with the workflow")
    defaults = deep_merge(schema_defaults(), LEGACY)
    return {**settings, **{key: deep_merge(defaults[key], settings[key]) for key in ("prepare", "fit", "features")}}


def unique_ids(photos: list[str]) -> list[str]:
    """An image id per photo (its file stem, made safe and unique)."""
    ids: list[str] = []
    for photo in photos:
        stem = re.sub(r"[^A-Za-z0-9_.-]", "_", Path(photo).stem).lstrip("._-") or "photo"
        candidate, n = stem, 2
        while candidate in ids:
            candidate, n = f"{stem}_{n}", n + 1
        ids.append(candidate)
    return ids


def _fit(prepared: Path, work: Path, settings: dict[str, Any], threads: int, log: logging.Logger,
         step: Callable[[str], None]) -> Path:
    """The three fit stages of one photo; returns the normals folder (its state says if a stage failed)."""

    fit = settings["fit"]
    common = {"variant": settings["variant"], "threads": threads, "full_effects": fit["full_effects"], "log": log,
              "sample_seed": fit["sample_seed"]}
    step("fit_geometry")
    jobs.geometry_job(str(prepared), str(work / "geometry"), GeometrySettings(**fit["geometry"]), **common)
    step("fit_material")
    jobs.material_job(str(prepared), str(work / "geometry"), str(work / "material"), MaterialSettings(**fit["material"]), **common)
    step("fit_normals")
    jobs.normals_job(str(prepared), str(work / "material"), str(work / "normals"), NormalSettings(**fit["normals"]), **common)
    return work / "normals"


def predict_photo(photo: str, image_id: str, model: VotingModel, physics_table: dict[str, PhysicsEntry], out: Path,
                  threads: int, log: logging.Logger, step: Callable[[str], None], render: bool = False) -> Prediction:
    """Prepare, fit (when the model needs it, or ``render``), featurise and classify one photo into ``out/<image_id>/``.

    With a fit, ``physics.json`` names its folder (``fit``): the BRDF, normal map and scene a renderer needs.
    """
    settings = training_settings(model)
    work = out / image_id
    step("prepare")
    record = prepare_image(image_id, photo, work / "prepared", PrepareSettings(**settings["prepare"]),
                           StructureSettings(**settings["features"]["structure"]))
    if record["status"] != "accepted":
        return Prediction(photo, image_id, None, None, None, record["reason"])
    note = str((record.get("scale") or {}).get("note", ""))
    sources = model_sources(model)
    dirs = {"photo": work / "prepared"}
    if "fitted" in sources or render:
        dirs["fitted"] = _fit(work / "prepared", work / "fit", settings, threads, log, step)
    step("features")
    tables, tile_tables = {}, {}
    tiled = scored_with_tiles(model)
    for source in sources:
        if source not in dirs:
            raise ValueError(f"model reads {source!r} features, which a photo does not have")
        row = features_job(image_id, None, source, photo, str(dirs[source]), settings["features"],
                           str(work / "features" / f"{source}.parquet"), str(work / "features" / f"{source}.png"),
                           tiles_path=str(work / "features" / f"{source}.tiles.parquet") if tiled else None,
                           prepared_dir=str(work / "prepared"))
        tables[source] = pd.DataFrame([row])
        if tiled:
            tile_tables[source] = pd.read_parquet(work / "features" / f"{source}.tiles.parquet")
    step("classify")
    table = joined_table(tables)
    row = table.iloc[0]
    if row["status"] != STATUS_OK:
        return Prediction(photo, image_id, None, None, None, f"{photo}: {row['reason']}")
    result = predict(model, table, joined_tiles(tables, tile_tables) if tiled else None).iloc[0]
    posteriors = {c: float(result[posterior_column(c)]) for c in model.classes}
    target = work / "physics.json"
    write_json(target, {"image_id": image_id, "photo": str(photo), "predicted_class": str(result["predicted_class"]),
                        "posteriors": posteriors, "model": model.metadata.get("arrays_sha256"),
                        "fit": str(dirs["fitted"]) if "fitted" in dirs else None, "prepare_note": note or None,
                        "physics": physics_for(posteriors, physics_table)})
    return Prediction(photo, image_id, str(result["predicted_class"]), max(posteriors.values()), str(target), note=note)
