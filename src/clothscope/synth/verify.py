"""Check that regenerated synthetic images reproduce the committed dataset.

Ground truth must match exactly (maps bit for bit, the truth record except its
``provenance``); images within one 8-bit code value (1/255), except for at most
:data:`OUTLIER_SHARE` of the values, which may differ by up to
:data:`OUTLIER_TOLERANCE`: Dr.Jit compiles its kernels for the host CPU, so the
multi-bounce estimates of the sheer class differ in their last bits between CPUs
(chiffon_charcoal: 14 of 196608 values off by 2-3 codes on an AMD EPYC).
"""
from __future__ import annotations

import json
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from clothscope.core.atomic import write_text
from clothscope.core.imageio import read_png
from clothscope.core.truth import truth_paths

IMAGE_TOLERANCE = 1.0 / 255.0
#: Share of values that may exceed IMAGE_TOLERANCE, and by how much at most.
OUTLIER_SHARE = 1e-3
OUTLIER_TOLERANCE = 4.0 / 255.0


def truth_record(path: Path) -> dict[str, Any]:
    """Truth JSON without the provenance block (timings, library paths)."""
    record = json.loads(path.read_text(encoding="utf-8"))
    record.pop("provenance", None)
    return record


def compare_image(regenerated: str | os.PathLike[str], committed: str | os.PathLike[str]) -> dict[str, Any]:
    """Compare one regenerated image and its truth with the committed copy."""
    new, old = Path(regenerated), Path(committed)
    new_truth, old_truth = truth_paths(new), truth_paths(old)
    diff = np.abs(read_png(new) - read_png(old))
    image_diff = float(diff.max())
    outliers = float((diff > IMAGE_TOLERANCE + 1e-6).mean())
    maps_equal = all(np.array_equal(read_png(new_truth[k]), read_png(old_truth[k])) for k in ("normal", "height"))
    fold_equal = np.array_equal(np.load(new_truth["fold"]), np.load(old_truth["fold"]))
    record_equal = truth_record(new_truth["json"]) == truth_record(old_truth["json"])
    truth_equal = bool(maps_equal and fold_equal and record_equal)
    return {
        "image_id": new.stem,
        "max_image_diff_255": round(image_diff * 255, 3),
        "share_over_1_255": round(outliers, 6),
        "truth_identical": truth_equal,
        "reproduced": bool(truth_equal and image_diff <= OUTLIER_TOLERANCE + 1e-6 and outliers <= OUTLIER_SHARE),
    }


def compare_datasets(regenerated_images: Iterable[str | os.PathLike[str]], committed_root: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """Compare every regenerated ``<root>/<class>/<id>.png`` with ``committed_root/<class>/<id>.png``."""
    rows = []
    for image in map(Path, regenerated_images):
        committed = Path(committed_root) / image.parent.name / image.name
        if not committed.is_file():
            rows.append({"image_id": image.stem, "max_image_diff_255": -1.0, "share_over_1_255": -1.0, "truth_identical": False,
                         "reproduced": False})
            continue
        rows.append(compare_image(image, committed))
    return rows


def write_report(rows: list[dict[str, Any]], target: str | os.PathLike[str]) -> None:
    """Write the comparison as TSV."""
    write_text(target, pd.DataFrame(rows).to_csv(sep="\t", index=False, lineterminator="\n"))


def check_job(regenerated_images: Iterable[str | os.PathLike[str]], committed_root: str | os.PathLike[str],
              target: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The ``check_synthetic`` rule: compare the regenerated set with the committed one and write the TSV report."""
    rows = compare_datasets(regenerated_images, committed_root)
    write_report(rows, target)
    return rows
