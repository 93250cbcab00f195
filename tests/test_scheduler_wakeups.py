"""scheduler_wakeups.py: the Snakemake driver writes its own figures at exit; two runs' outputs are compared."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import scheduler_wakeups  # noqa: E402


def test_the_driver_runs_snakemake_and_writes_its_cpu_seconds_and_timers(tmp_path):
    stats = tmp_path / "stats.json"
    run = subprocess.run([sys.executable, "-c", scheduler_wakeups.DRIVER, "snakemake", "--version"], capture_output=True, text=True,
                         env=dict(os.environ, CLOTHSCOPE_SCHEDULER_STATS=str(stats)), check=True)
    assert run.stdout.strip()[0].isdigit()
    figures = json.loads(stats.read_text())
    assert figures["cpu_s"] > 0 and figures["timers"] == 0


def test_same_outputs_tells_identical_tables_from_different_ones(tmp_path):
    runs = [tmp_path / name for name in ("a", "b", "c")]
    for run, value in zip(runs, (1.0, 1.0, 2.0)):
        (run / "features" / "fitted").mkdir(parents=True)
        pd.DataFrame({"image_id": ["y", "x"], "f": [value, 0.5]}).to_parquet(run / "features" / "fitted" / "table.parquet")
    assert "identical" in scheduler_wakeups.same_outputs(runs[0], runs[1])[0]
    assert "DIFFERENT" in scheduler_wakeups.same_outputs(runs[0], runs[2])[0]
