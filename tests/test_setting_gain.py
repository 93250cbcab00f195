"""setting_gain.py: the AFTER copy of a run, and the pairing of two runs' scores."""
from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import setting_gain  # noqa: E402


def write_run(run: Path, correct: dict[str, int], record: int, n: int = 10) -> None:
    """A results folder with a feature-set report and a classifier-of-record accuracy."""
    (run / "reports" / "fitted").mkdir(parents=True)
    (run / "reports" / "feature_sets.csv").write_text(
        "feature_set,correct,n\n" + "".join(f"{name},{k},{n}\n" for name, k in correct.items()), encoding="utf-8")
    (run / "reports" / "fitted" / "accuracy.json").write_text(json.dumps({"correct": record, "n": n}), encoding="utf-8")


def test_rerun_copies_the_fits_drops_what_the_setting_changes_and_runs_with_the_overlay(tmp_path, monkeypatch):
    before, after = tmp_path / "run", tmp_path / "run_p"
    for path in ("prepared/a/status.json", "fit/a/normals/state.json", "features/photo/a.parquet", "features/truth/a.parquet"):
        (before / path).parent.mkdir(parents=True, exist_ok=True)
        (before / path).write_text("x", encoding="utf-8")
    (after / "stale").mkdir(parents=True)
    calls = []
    monkeypatch.setattr(setting_gain, "ROOT", tmp_path)
    monkeypatch.setattr(setting_gain, "snakemake", lambda args: calls.append(args))
    setting_gain.rerun_with(before, after, Path("config/overlays/x.yaml"), ["features/photo"], "sheet.tsv")
    assert (after / "fit/a/normals/state.json").is_file() and (after / "features/truth/a.parquet").is_file()
    assert not (after / "features/photo").exists() and not (after / "stale").exists()
    assert calls == [["--configfile", "config/config.yaml", "config/overlays/x.yaml", "--rerun-triggers", "mtime",
                      "--config", "results=run_p", "samples=sheet.tsv"]]


def test_a_drop_pattern_removes_every_match_and_nothing_else(tmp_path, monkeypatch):
    before, after = tmp_path / "run", tmp_path / "run_p"
    for path in ("prepared/a/status.json", "fit/a/normals/state.json", "fit/a/material/state.json",
                 "fit/b/normals/state.json", "features/fitted/a.parquet"):
        (before / path).parent.mkdir(parents=True, exist_ok=True)
        (before / path).write_text("x", encoding="utf-8")
    monkeypatch.setattr(setting_gain, "ROOT", tmp_path)
    monkeypatch.setattr(setting_gain, "snakemake", lambda args: None)
    setting_gain.rerun_with(before, after, Path("x.yaml"), ["fit/*/normals"], None)
    assert not (after / "fit/a/normals").exists() and not (after / "fit/b/normals").exists()
    assert (after / "fit/a/material/state.json").is_file() and (after / "features/fitted/a.parquet").is_file()


def test_pairs_are_scored_set_by_set_and_runs_of_other_images_are_refused(tmp_path):
    write_run(tmp_path / "a", {"structure_photo": 6, "lbp_photo": 5}, record=7)
    write_run(tmp_path / "b", {"structure_photo": 8, "lbp_photo": 5}, record=6)
    rows = setting_gain.pair_rows(tmp_path / "a", tmp_path / "b").set_index("feature_set")
    assert rows.loc["structure_photo", ["before", "after"]].tolist() == [6, 8]
    assert rows.loc[setting_gain.RECORD, ["before", "after"]].tolist() == [7, 6]
    write_run(tmp_path / "c", {"structure_photo": 8}, record=6, n=12)
    with pytest.raises(SystemExit, match="scored different images"):
        setting_gain.pair_rows(tmp_path / "a", tmp_path / "c")


def test_rerun_refuses_a_before_run_without_fits_in_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(setting_gain, "ROOT", tmp_path)
    monkeypatch.setattr(sys, "argv", ["setting_gain.py", "--rerun", "x.yaml", "empty:empty_p"])
    (tmp_path / "empty" / "prepared").mkdir(parents=True)
    with pytest.raises(SystemExit, match="empty:empty_p: empty has no fit, features folder to copy"):
        setting_gain.main()
    assert not (tmp_path / "empty_p").exists()


def test_the_fit_changes_count_the_refitted_images_and_the_periods_within_five_percent(tmp_path):
    for run, psnr, period in (("a", [30.0, 31.0, 20.0], [0.01, 0.2, -1.0]), ("b", [30.0, 32.0, 21.0], [0.01, 0.04, -1.0])):
        (tmp_path / run / "reports").mkdir(parents=True)
        (tmp_path / run / "reports" / "fit_accuracy.csv").write_text(
            "image_id,psnr_db,period_error\n" + "".join(f"i{k},{p},{e}\n" for k, (p, e) in enumerate(zip(psnr, period))),
            encoding="utf-8")
    changes = setting_gain.fit_changes(tmp_path / "a", tmp_path / "b")
    assert changes["images"] == 3 and changes["refitted_differently"] == 2 and changes["periodic"] == 2
    assert (changes["psnr_before"], changes["psnr_after"]) == (25.5, 26.5)
    assert (changes["period_within_5pct_before"], changes["period_within_5pct_after"]) == (1, 2)
    assert setting_gain.fit_changes(tmp_path / "a", tmp_path / "missing") is None
    assert "| 3 | 2 | 25.50 dB | 26.50 dB | 1/2 | 2/2 |" in "\n".join(setting_gain.fit_lines([changes]))
