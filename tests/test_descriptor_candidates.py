"""descriptor_candidates.py: the candidate descriptors and the per-set summary."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import descriptor_candidates as dc  # noqa: E402


def weave(kind: str, size: int = 96, period: int = 8) -> np.ndarray:
    """A canonical field of raised floats: a plain weave's checkerboard or a 2/1 twill's diagonal, with noise."""
    y, x = np.mgrid[0:size, 0:size] // period
    up = (x + y) % 2 == 0 if kind == "plain" else (x - y) % 3 == 0
    return up.astype(float) + 0.05 * np.random.default_rng(0).standard_normal((size, size))


@pytest.mark.parametrize("name", list(dc.CANDIDATES))
def test_candidates_are_finite_and_a_quarter_turn_leaves_them(name):
    describe = dc.CANDIDATES[name]
    field = weave("twill")
    values = describe(field)
    turned = describe(np.rot90(field))
    assert values.keys() == turned.keys() and all(key.startswith(name + "_") for key in values)
    assert np.isfinite(list(values.values())).all()
    assert max(abs(values[k] - turned[k]) for k in values) < 1e-9


def test_the_autocorrelation_rings_tell_a_plain_weave_from_a_twill():
    """A plain weave's autocorrelation has a square's symmetry (no second angular harmonic); a twill's lines give it one."""
    plain, twill = dc.acf(weave("plain")), dc.acf(weave("twill"))
    one_period = int(np.argmin(abs(dc.ACF_RINGS - 1.0)))
    assert plain[f"acf_h2_{one_period}"] < 0.01 < plain[f"acf_h4_{one_period}"]
    assert twill[f"acf_h2_{one_period}"] > 10 * plain[f"acf_h2_{one_period}"]


def test_summary_has_per_set_rows_their_sum_and_the_pool():
    rows = [{"run": run, "period": period, "columns": name, "correct": correct + k, "n": 30}
            for run, correct in (("results/b/run", 10), ("results/a/run", 5), ("pooled", 20))
            for period in dc.PERIODS for k, name in enumerate(dc.SCORED)]
    text = dc.summary(pd.DataFrame(rows))
    lines = [line for line in text.splitlines() if line.startswith("| ")]
    k = len(dc.SCORED)
    assert lines[1] == "| `results/b/run` | 30 | " + " | ".join(str(10 + i) for i in range(k)) + " |"
    assert lines[3] == "| all | 60 | " + " | ".join(str(15 + 2 * i) for i in range(k)) + " |"
    assert lines[4] == "| pooled | 30 | " + " | ".join(str(20 + i) for i in range(k)) + " |"
    assert len(lines) == 2 * 5
