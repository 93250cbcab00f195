"""fit_speed.py: the code of another commit that an ``at:<commit>`` variant fits with."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import fit_speed  # noqa: E402
import harness  # noqa: E402

ROOT = harness.ROOT


def committed(path: str, commit: str = "HEAD") -> bytes:
    return subprocess.run(["git", "show", f"{commit}:{path}"], cwd=ROOT, capture_output=True, check=True).stdout


def test_code_at_unpacks_the_commit_once(tmp_path):
    first_commit = subprocess.run(["git", "rev-list", "--max-parents=0", "HEAD"], cwd=ROOT, capture_output=True,
                                  text=True, check=True).stdout.split()[-1]
    copy = harness.code_at(first_commit, tmp_path)
    assert copy == tmp_path / first_commit
    assert (copy / "Snakefile").read_bytes() == committed("Snakefile", first_commit)
    assert not list(tmp_path.glob("*.partial"))
    (copy / "marker").write_text("kept")
    assert harness.code_at(first_commit[:10], tmp_path) == copy and (copy / "marker").is_file()


def test_code_at_names_an_unknown_commit(tmp_path):
    with pytest.raises(SystemExit, match="no commit 'no-such-commit'"):
        harness.code_at("no-such-commit", tmp_path)
    assert not list(tmp_path.iterdir())


def test_a_commit_variant_fits_with_the_default_preset():
    assert fit_speed.preset_and_overlay("at:d2ab236") == ("default", {})
    assert fit_speed.preset_and_overlay("fast") == fit_speed.VARIANTS["fast"]
