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
    assert record_hits(tmp_path).to_dict() == {"a": True, "b": False, "c": True}
    with pytest.raises(SystemExit, match="predictions.csv: no such file"):
        record_hits(tmp_path / "elsewhere")


def test_the_summed_and_banded_rows_pool_the_runs_images():
    rows = [("r1", "a", 3.0, True, True, True), ("r1", "b", 6.0, False, True, True), ("r1", "c", 9.0, True, False, False),
            ("r2", "d", 3.5, False, True, False), ("r2", "e", float("nan"), True, True, True)]
    bands = scale_bands()
    table = pd.DataFrame([{"run": run, "image_id": image, "working_period_px": period, "scale_band": scale_band(period, bands),
                           "vote_fitted": fitted, "vote_photo": photo, "record": record}
                          for run, image, period, fitted, photo, record in rows])
    assert list(table["scale_band"]) == ["under 4 px", "4-8 px", "8-16 px", "under 4 px", "no lattice"]
    text = markdown(table)
    assert "| `r1` | 3 | 2 | 2 | 2 | +1 / -1, p = 1 | +0 / -0, p = 1 |" in text
    assert f"| summed over the runs | 5 | 3 | 4 | 3 | +1 / -2, p = {mcnemar_p(1, 2):.2g} | +0 / -1, p = 1 |" in text
    assert "| under 4 px | 2 | 1 | 2 | 1 | +0 / -1, p = 1 | +0 / -1, p = 1 |" in text
    assert text.index("| 4-8 px |") < text.index("| 8-16 px |") < text.index("| no lattice |")
