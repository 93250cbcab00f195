"""photo_candidates.py: the photo's candidate lists and the per-run summary."""
from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import photo_candidates as pc  # noqa: E402

from clothscope.classify.feature_sets import PHOTO_GROUPS  # noqa: E402
from clothscope.features.structure import SPECTRUM_COLUMNS, STRUCTURE_COLUMNS, WEAVE_COLUMNS  # noqa: E402


def test_photo_spectrum_adds_the_spectrum_rings_to_the_photo_structure():
    columns = pd.Index([f"photo.{c}" for c in (*STRUCTURE_COLUMNS, *WEAVE_COLUMNS, *SPECTRUM_COLUMNS, "roughness")])
    sets = pc.photo_sets(columns)
    assert list(sets) == ["photo_structure", *PHOTO_GROUPS] and "photo_spectrum" in sets
    assert not any(c.startswith("photo.p_") for c in sets["photo_structure"])
    assert sets["photo_spectrum"] == sets["photo_structure"] + [f"photo.{c}" for c in SPECTRUM_COLUMNS]


def test_the_summary_counts_the_change_per_run_and_in_all():
    rows = []
    for run, (without, with_it) in {"a": (20, 23), "b": (30, 29)}.items():
        for label, correct in zip((*pc.LISTS, *pc.ALONE), (without, with_it, 19, 25)):
            rows.append({"run": run, "candidates": label, "correct": correct, "n": 36,
                         "folds_chose": "photo_structure 36" if label == pc.LISTS[1] else ""})
    text = pc.markdown(pd.DataFrame(rows))
    assert "| `a` | 36 | 20 | 23 | 19 | 25 | +3 |" in text
    assert "| `b` | 36 | 30 | 29 | 19 | 25 | -1 |" in text
    assert "| all | 72 | 50 | 52 | 38 | 50 | +2 |" in text
    assert "- `a`: photo_structure 36" in text
