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
