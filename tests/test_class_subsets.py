"""class_subsets.py: each subset's rows, and the report's cells for the fitted maps alone and the photo alone."""
from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import class_subsets as cs  # noqa: E402


def test_a_subset_keeps_the_rows_of_its_classes_in_every_source():
    table = pd.DataFrame({"image_id": ["a", "b", "c"], "fabric_class": ["satin", "velvet", "chiffon"]})
    subset = cs.of_classes({"fitted": table, "photo": table.iloc[::-1]}, ("satin", "chiffon"))
    assert [list(t["image_id"]) for t in subset.values()] == [["a", "c"], ["c", "a"]]


def test_the_report_gives_each_source_its_own_count_and_a_dash_where_unscored():
    row = {"set": "held-out", "experiment": "5 classes", "n": 30, "correct": 27, "accuracy": 0.9, "wilson_low": 0.744,
           "wilson_high": 0.965, "chance": 0.2, "folds_chose": "photo_structure 30",
           "auto_fitted_correct": 21, "auto_fitted_n": 30, "auto_fitted_accuracy": 0.7,
           "auto_photo_correct": 0, "auto_photo_n": 0, "auto_photo_accuracy": float("nan"),
           "vote_fitted_correct": 24, "vote_fitted_n": 30, "vote_fitted_accuracy": 0.8}
    text = cs.report(pd.DataFrame([row]), {"feature_set": "auto", "subspace": "discriminant", "reg": "auto"})
    assert "| held-out | 5 classes | 90.0% (27/30) | 74.4-96.5% | 20.0% | photo_structure 30 | 70.0% (21/30) | - | 80.0% (24/30) |" in text
    assert [s.name for s in cs.SOURCE_SETS] == ["auto_fitted", "auto_photo", "vote_fitted"]


def test_a_run_without_its_feature_tables_stops_with_one_line_naming_the_missing_table(tmp_path):
    (tmp_path / "features" / "fitted").mkdir(parents=True)
    (tmp_path / "features" / "fitted" / "table.parquet").write_bytes(b"")
    with pytest.raises(SystemExit) as stop:
        cs.require_tables(tmp_path)
    message = str(stop.value)
    assert "\n" not in message and message.startswith(str(tmp_path / "features" / "photo" / "table.parquet"))
    assert "no such feature table" in message
