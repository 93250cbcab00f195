"""``results_doc.py --keep-earlier``: a section whose file is missing keeps the replaced page's measured text."""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))

import results_doc  # noqa: E402


def test_only_sections_not_measured_here_keep_the_earlier_measured_text():
    earlier = results_doc.results_page([
        "# Measured results\n\nold header",
        "## Speed\n\nSource: `results/bench/speed.md` (2026-11-20).\n\n| a |\n|---|\n| 1 |",
        "## Accuracy\n\nSource: `results/bench/accuracy.md` (2026-11-20).\n\n90%",
        "## Memory\n\nnot measured: run `memory.py`",
    ])
    fresh = [
        "# Measured results\n\nnew header",
        "## Speed\n\nnot measured: run `speed.py`",
        "## Accuracy\n\nSource: `results/bench/accuracy.md` (2026-11-24).\n\n95%",
        "## Memory\n\nnot measured: run `memory.py`",
        "## Scaling\n\nnot measured: run `scaling.py`",
    ]
    kept = results_doc.keep_earlier(fresh, results_doc.earlier_sections(earlier))
    assert kept[0] == fresh[0]
    assert kept[1].startswith("## Speed\n\nSource: `results/bench/speed.md` (2026-11-20).") and kept[1].endswith("| 1 |")
    assert kept[2:] == fresh[2:]
    page = results_doc.results_page(kept)
    assert "- Speed\n- Accuracy\n- Memory\n- Scaling" in page and page.count("## Speed") == 1


def test_only_the_named_sections_are_rewritten_and_a_new_one_is_added():
    earlier = results_doc.earlier_sections(results_doc.results_page([
        "# Measured results\n\nold header",
        "## Speed\n\nSource: `results/bench/speed.md` (2026-11-20).\n\n12 s",
        "## Accuracy\n\nSource: `results/bench/accuracy.md` (2026-11-20).\n\n90%",
    ]))
    fresh = ["# Measured results\n\nnew header", "## Speed\n\nnot measured: run `speed.py`",
             "## Accuracy\n\nSource: `results/bench/accuracy.md` (2026-11-27).\n\n95%", "## Period\n\nnew section"]
    kept = results_doc.only_titles(fresh, earlier, ["Accuracy"])
    assert kept == [fresh[0], "## Speed\n\nSource: `results/bench/speed.md` (2026-11-20).\n\n12 s", fresh[2], fresh[3]]
    with pytest.raises(SystemExit, match="no section titled Nothing"):
        results_doc.only_titles(fresh, earlier, ["Nothing"])


def _runs(tmp_path: Path) -> list:
    """Two runs: ``here`` has reports on this machine, ``away`` does not."""
    return [results_doc.Run(label, tmp_path / label, tmp_path / label / "samples.tsv", f"make {label}")
            for label in ("here", "away")]


def test_runs_whose_reports_are_not_here_keep_their_earlier_rows(tmp_path):
    here, away = _runs(tmp_path)
    (here.folder / "reports" / "fitted").mkdir(parents=True)
    (here.folder / "reports" / "fitted" / "accuracy.json").write_text(
        '{"correct": 9, "n": 10, "accuracy": 0.9, "wilson_low": 0.6, "wilson_high": 0.98, "chance_uniform": 0.5,'
        ' "selected_feature_sets": {"photo_structure": 10}}', encoding="utf-8")
    earlier = (f"## Classifier of record (LOOCV)\n\nSource: `{results_doc.shown(here.folder)}/reports/fitted/accuracy.json` "
               f"(2026-11-01), `{results_doc.shown(away.folder)}/reports/fitted/accuracy.json` (2026-11-02).\n\n"
               "| run | source | correct |\n|---|---|---|\n| here | fitted | 1/10 |\n| away | fitted | 7/8 |")
    section = results_doc.classifier_section([here, away], earlier)
    assert "| here | fitted | 9/10 | 90.0% |" in section and "1/10" not in section
    assert "| away | fitted | 7/8 |" in section and "not measured" not in section
    assert f"`{results_doc.shown(away.folder)}/reports/fitted/accuracy.json` (2026-11-02)." in section
    assert "not measured: run `make away`" in results_doc.classifier_section([here, away])


def test_runs_whose_reports_are_not_here_keep_their_earlier_columns(tmp_path):
    here, away = _runs(tmp_path)
    (here.folder / "reports").mkdir(parents=True)
    (here.folder / "reports" / "feature_sets.csv").write_text(
        "feature_set,description,status,accuracy,correct,n\nstructure_photo,photo structure,ok,0.5,5,10\n", encoding="utf-8")
    (here.folder / "reports" / "feature_sets.md").write_text("Inverse rendering cost 10 points.\n", encoding="utf-8")
    earlier = ("## Feature sets side by side\n\nSource: x.\n\n- away: Inverse rendering bought 3 points.\n\n"
               "| feature set | what | here | away |\n|---|---|---|---|\n"
               "| `structure_photo` | photo structure | 1.0% (1/10) | 75.0% (6/8) |\n| `paper_truth` | truth | - | 50.0% (4/8) |")
    section = results_doc.feature_sets_section([here, away], earlier)
    assert "| `structure_photo` | photo structure | 50.0% (5/10) | 75.0% (6/8) |" in section
    assert "| `paper_truth` | truth | - | 50.0% (4/8) |" in section
    assert "- here: Inverse rendering cost 10 points.\n- away: Inverse rendering bought 3 points." in section


def test_a_run_not_on_this_machine_keeps_its_earlier_rule_table(tmp_path):
    """The per-rule section keeps a run's measured table from the page being replaced; a run never measured says how."""
    earlier = ("## Time and memory per rule\n\nintro\n\n### gone\n\nSource: `x/**/*.tsv` (3 files).\n\n| rule | jobs |\n|---|---|\n"
               "| `prepare` | 3 |\n\n### never\n\nnot measured: run `make never`")
    runs = [results_doc.Run("gone", tmp_path / "gone", tmp_path / "s.tsv", "make gone"),
            results_doc.Run("never", tmp_path / "never", tmp_path / "s.tsv", "make never")]
    section = results_doc.rule_times_section(runs, earlier)
    assert "### gone\n\nSource: `x/**/*.tsv` (3 files).\n\n| rule | jobs |\n|---|---|\n| `prepare` | 3 |" in section
    assert "### never\n\nnot measured: run `make never`" in section
    assert "make gone" not in section


def test_photos_without_ground_truth_have_no_fit_accuracy_column_or_command(tmp_path):
    real = results_doc.Run("real", tmp_path / "real", tmp_path / "s.tsv", "make real", truth=False)
    synthetic = results_doc.Run("synthetic", tmp_path / "synthetic", tmp_path / "s.tsv", "make synthetic")
    section = results_doc.fit_accuracy_section([real, synthetic])
    assert "not measured: run `make synthetic`" in section and "make real" not in section
