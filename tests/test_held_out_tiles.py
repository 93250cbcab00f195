"""held_out_tiles.py: scoring each held-out image with its tiles, beside its whole row, per run."""
from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import held_out_tiles as ht  # noqa: E402


def test_the_summary_counts_the_change_per_run_and_the_proxy_in_all():
    rows = []
    for run, counts in {"a": {"photo's sets": (20, 23), "photo_structure": (19, 22)},
                        "b": {"photo's sets": (30, 29), "photo_structure": (30, 30), "classifier of record": (38, 39)}}.items():
        for label, both in counts.items():
            rows += [{"run": run, "candidates": label, "mode": mode, "correct": c, "n": 36} for mode, c in zip(ht.MODES, both)]
    text = ht.markdown(pd.DataFrame(rows))
    assert "| `a` | photo's sets | 36 | 20 | 23 | +3 |" in text
    assert "| `b` | classifier of record | 36 | 38 | 39 | +1 |" in text
    assert "| all | photo's sets | 72 | 50 | 52 | +2 |" in text  # the proxy only, not the other lists

