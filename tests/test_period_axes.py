"""period_axes.py: periods within 5% and the classifier's proxy, with the run's period pick and with a candidate pick."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import period_axes as pa  # noqa: E402


def test_a_period_counts_when_within_five_percent_of_the_truth_as_seen(tmp_path, monkeypatch):
    windows = []
    monkeypatch.setattr(pa, "window_seen_scale", lambda record, window: windows.append(window) or 1.1)  # 10% nearer
    truth = tmp_path / "truth" / "twill"
    truth.mkdir(parents=True)
    for image_id, periodic in (("a", True), ("b", True), ("c", True), ("d", False)):
        (truth / f"{image_id}.truth.json").write_text(json.dumps(
            {"periodic": periodic, "thread_period_px": 10.0 if periodic else None, "course_period_px": None}))
    run = tmp_path / "run"
    for image_id, period in (("a", 11.3), ("b", 31.1), ("d", 5.0)):  # c: never prepared
        (run / "prepared" / image_id).mkdir(parents=True)
        status = {"scale": {"native_period_px": period}, "settings": {"period_window": 512} if image_id == "b" else {}}
        (run / "prepared" / image_id / "status.json").write_text(json.dumps(status))
    records = pa.truth_records(tmp_path / "truth")
    assert sorted(records) == ["a", "b", "c"]
    ratios = pa.recorded_ratios(run, records, 1024)
    assert windows == [1024, 512, 1024]  # the window each period was read on: b's status names its own
    assert pa.periods_within(ratios) == 1  # a: 11.3 against 11.0; b: a twill rib; c: no status
    assert pa.periods_too_long(ratios) == 1  # b: 31.1 against 11.0


def test_the_summary_sums_the_sets():
    rows = [{"set": s, "run": r, "folder": f"{s}_{r}", "periodic": p, "period_within_5pct": w, "period_too_long": t,
             "proxy_correct": c, "images": n}
            for s, p, n, counts in (("m", 30, 30, ((24, 24), (3, 2), (24, 25))), ("w", 36, 36, ((23, 24), (5, 5), (27, 23))))
            for r, w, t, c in zip(pa.RUNS, *counts)]
    text = pa.markdown(pd.DataFrame(rows), "axes_harmonic")
    assert "within 5%, axes_harmonic" in text
    assert "| `m` | 30 | 24 | 24 | 3 | 2 | 30 | 24 | 25 |" in text
    assert "| `w` | 36 | 23 | 24 | 5 | 5 | 36 | 27 | 23 |" in text
    assert "| all | 66 | 47 | 48 | 8 | 7 | 66 | 51 | 48 |" in text


def test_the_native_summary_sums_the_field_folders():
    table = pd.DataFrame([{"set": "a/field", "periodic": 30, "weighted": 24, "axes": 25, "axes_harmonic": 27},
                          {"set": "b/field", "periodic": 36, "weighted": 24, "axes": 29, "axes_harmonic": 29}])
    text = pa.native_markdown(table, ["weighted", "axes", "axes_harmonic"], ["shading"], None)
    assert "| `a/field` | 30 | 24 | 25 | 27 |" in text and "| all | 66 | 48 | 54 | 56 |" in text
    assert "| field | periodic | `weighted` | `axes` | `axes_harmonic` |" in text
    assert "on the shading" in text and "differ" not in text


def test_two_fields_name_their_columns_and_the_sheets_count_photos_whose_periods_differ(tmp_path, monkeypatch):
    assert pa.pick_columns(["axes"], ["shading"]) == ["axes"]
    assert pa.pick_columns(["axes", "weighted"], ["shading", "luminance"]) == [
        "shading axes", "shading weighted", "luminance axes", "luminance weighted"]
    readings = {"a.jpg": {"shading axes": 4.0, "luminance axes": 4.1},  # within 5%: the same
                "b.jpg": {"shading axes": 2.5, "luminance axes": 5.0},  # a harmonic on one field
                "c.jpg": {"shading axes": None, "luminance axes": 6.0},  # a lattice on one field only
                "d.jpg": {"shading axes": None, "luminance axes": None}}  # none on either: the same
    monkeypatch.setattr(pa, "native_periods", lambda path, peaks, fields: readings[path.name])
    monkeypatch.setattr(pa, "ROOT", tmp_path)
    pd.DataFrame({"image_id": list("abcd"), "path": [f"{i}.jpg" for i in "abcd"]}).to_csv(tmp_path / "s.tsv", sep="\t")
    row = pa.sheet_row(tmp_path / "s.tsv", "axes", ["shading", "luminance"])
    assert (row["photos"], row["differ"]) == (4, 2)
    table = pd.DataFrame([{"set": "m/field", "periodic": 30, "shading axes": 25, "luminance axes": 27}])
    text = pa.native_markdown(table, ["shading axes", "luminance axes"], ["shading", "luminance"], pd.DataFrame([row]))
    assert "| `m/field` | 30 | 25 | 27 |" in text and "| all | 4 | 2 |" in text
