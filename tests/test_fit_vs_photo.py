"""fit_vs_photo.py: the record's LOOCV hits read back, and the per-run and pooled paired counts of its report."""
from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
from fit_vs_photo import markdown, record_hits, scale_band, scale_bands  # noqa: E402

from clothscope.classify.feature_sets import mcnemar_p  # noqa: E402


def test_record_hits_read_the_loocv_rows_only(tmp_path):
    reports = tmp_path / "reports" / "fitted"
    reports.mkdir(parents=True)
    pd.DataFrame({"image_id": ["a", "b", "c", "q"], "true_class": ["x", "y", "x", ""],
                  "predicted_class": ["x", "x", "x", "y"], "split": ["loocv", "loocv", "loocv", "query"]}
                 ).to_csv(reports / "predictions.csv", index=False)
    hits = record_hits(tmp_path)
    assert hits["record"].to_dict() == {"a": True, "b": False, "c": True} and list(hits["fabric_class"]) == ["x", "y", "x"]
    with pytest.raises(SystemExit, match="predictions.csv: no such file"):
        record_hits(tmp_path / "elsewhere")


def test_the_summed_and_banded_rows_pool_the_runs_images():
    rows = [("r1", "a", "x", 3.0, True, True, True, False), ("r1", "b", "y", 6.0, False, True, True, True),
            ("r1", "c", "x", 9.0, True, False, False, False), ("r2", "d", "y", 3.5, False, True, False, True),
            ("r2", "e", "x", float("nan"), True, True, True, True)]
    bands = scale_bands()
    table = pd.DataFrame([{"run": run, "image_id": image, "fabric_class": fabric, "working_period_px": period,
                           "scale_band": scale_band(period, bands), "vote_fitted": fitted, "vote_photo": photo,
                           "record": record, "record_photo": record_photo}
                          for run, image, fabric, period, fitted, photo, record, record_photo in rows])
    assert list(table["scale_band"]) == ["under 4 px", "4-8 px", "8-16 px", "under 4 px", "no lattice"]
    text = markdown(table)
    assert "| `r1` | 3 | 2 | 2 | 2 | 1 | +1 / -1, p = 1 | +0 / -0, p = 1 | +1 / -0, p = 1 |" in text
    assert (f"| summed over the runs | 5 | 3 | 4 | 3 | 3 | +1 / -2, p = {mcnemar_p(1, 2):.2g} | +0 / -1, p = 1 | "
            "+1 / -1, p = 1 |") in text
    assert "| under 4 px | 2 | 1 | 2 | 1 | 1 | +0 / -1, p = 1 | +0 / -1, p = 1 | +1 / -1, p = 1 |" in text
    assert text.index("| 4-8 px |") < text.index("| 8-16 px |") < text.index("| no lattice |")
    assert "| x | 3 | 3 | 2 | 2 | 1 | +1 / -0, p = 1 |" in text and "| y | 2 | 0 | 2 | 1 | 2 |" in text
