"""period_oracle.py: counting prepare's period errors, and the per-set summary."""
from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import period_oracle  # noqa: E402


def test_prepare_errors_count_wrong_periods_and_the_harmonic_among_them():
    ratios = [1.0, 1.03, 0.707, 0.71, 0.5, 0.0, None]  # right, right, harmonic, harmonic, wrong, no lattice, no truth
    table = pd.DataFrame({"period": ["prepare"] * len(ratios) + ["truth"], "prepare_over_truth": ratios + [0.5]})
    assert period_oracle.prepare_errors(table) == {"periodic": 6, "prepare_wrong": 4, "harmonic": 2}


def test_summary_has_a_row_per_set_in_order_and_their_sum():
    rows = []
    for run, correct, n in (("results/b/run", (10, 12, 12, 14), 20), ("results/a/run", (5, 6, 7, 8), 10)):
        rows += [{"run": run, "period": name, "correct": k, "n": n, "periodic": n, "prepare_wrong": 3, "harmonic": 2}
                 for name, k in zip(period_oracle.PERIODS, correct)]
    text = period_oracle.summary(pd.DataFrame(rows))
    lines = [line for line in text.splitlines() if line.startswith("| ")]
    assert lines[1] == "| `results/b/run` | 20 | 10 | 12 | 12 | 14 | 3 of 20 (2) |"
    assert lines[2] == "| `results/a/run` | 10 | 5 | 6 | 7 | 8 | 3 of 10 (2) |"
    assert lines[3] == "| all | 30 | 15 | 18 | 19 | 22 | 6 of 30 (4) |"
