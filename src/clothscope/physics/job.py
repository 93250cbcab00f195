"""The ``physics`` rule: each image's ArcSim material, from the classifier's record of it.

Reads the per-image records the ``classify`` rule wrote (:data:`clothscope.classify.outputs.RECORDS_FILE`)
and writes one JSON per image: the record plus ``physics``, the material of the likeliest class with
the posterior-weighted mean and spread (:func:`clothscope.physics.materials.physics_for`), or None for an
image that was not classified (its status and reason say why).
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from clothscope.core.atomic import write_json
from clothscope.physics.materials import load_physics_table, physics_for, physics_table_record


def physics_job(records_path: str | os.PathLike[str], physics_path: str | os.PathLike[str],
                physics_paths: dict[str, str], log: Any = None, table_copy: str | os.PathLike[str] | None = None) -> int:
    """Write every image's physics JSON; returns how many got parameters.

    Parameters
    ----------
    records_path
        The classifier's per-image records (JSON list).
    physics_path
        ``config/physics.yaml``.
    physics_paths
        Image id to the JSON to write; the records and these ids must name the same images.
    table_copy
        Where to keep the table as JSON beside the model (:data:`clothscope.classify.outputs.MODEL_PHYSICS_FILE`),
        for ``clothscope predict``; None: nowhere.

    Raises
    ------
    ValueError
        When the records and ``physics_paths`` do not name the same images.
    """
    table = load_physics_table(physics_path)
    records = json.loads(Path(records_path).read_text(encoding="utf-8"))
    ids = [str(r["image_id"]) for r in records]
    unknown = sorted(set(ids) - set(physics_paths))
    if unknown:
        raise ValueError(f"{records_path}: no physics output path for image(s) {', '.join(unknown)}")
    missing = sorted(set(physics_paths) - set(ids))
    if missing:
        raise ValueError(f"{records_path}: the feature table has no row for image(s) {', '.join(missing)}")
    with_parameters = 0
    for record in records:
        physics = physics_for(record["posteriors"], table) if record["posteriors"] else None
        with_parameters += physics is not None
        write_json(physics_paths[str(record["image_id"])], {**record, "physics": physics})
    if table_copy is not None:
        write_json(table_copy, physics_table_record(table) | {"from": str(physics_path)})
    if log is not None:
        log.info("physics for %d of %d images", with_parameters, len(records))
    return with_parameters
