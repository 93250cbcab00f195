"""Opt-in: one image through workflow/profiles/slurm on a live Slurm cluster.

Skipped unless CLOTHSCOPE_SLURM_TEST=1, `sinfo` answers and the executor plugin is installed
(`bash bootstrap.sh --slurm`); a local cluster: `bash workflow/cluster/single_node_slurm.sh`.
On a multi-node cluster set CLOTHSCOPE_SLURM_TEST_DIR to a folder every node sees.
"""
from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import ROOT, non_finite_outputs, run_snakemake

IMAGE = "velvet_navy"


def skip_reason() -> str | None:
    if os.environ.get("CLOTHSCOPE_SLURM_TEST") != "1":
        return "opt-in: set CLOTHSCOPE_SLURM_TEST=1 to run on a live Slurm cluster"
    if shutil.which("sinfo") is None:
        return "no Slurm client (sinfo) on PATH"
    if subprocess.run(["sinfo", "-h"], capture_output=True, timeout=60).returncode != 0:
        return "sinfo does not answer: no Slurm controller reachable"
    if importlib.util.find_spec("snakemake_executor_plugin_slurm") is None:
        return "executor plugin missing: bash bootstrap.sh --slurm"
    return None


SKIP = skip_reason()
pytestmark = [pytest.mark.slurm, pytest.mark.slow, pytest.mark.skipif(SKIP is not None, reason=str(SKIP))]


def test_one_image_through_the_slurm_profile_gives_a_finite_feature_row(tmp_path):
    base = Path(os.environ.get("CLOTHSCOPE_SLURM_TEST_DIR") or tmp_path)
    base.mkdir(parents=True, exist_ok=True)
    sheet_lines = (ROOT / "config" / "samples.tsv").read_text().splitlines()
    rows = [line for line in sheet_lines[1:] if line.split("\t")[0] == IMAGE]
    assert rows, f"{IMAGE} not in config/samples.tsv"
    sheet = base / "slurm_sheet.tsv"
    sheet.write_text("\n".join([sheet_lines[0], *rows]) + "\n")
    results = base / "slurm_results"
    table = results / "features" / "fitted" / "table.parquet"

    run = run_snakemake(ROOT, "--profile", "workflow/profiles/slurm", "--slurm-init-seconds-before-status-checks", "10",
                        "--config", f"samples={sheet}", f"results={results}", "preset=fast", "--", str(table), timeout=3600)

    log = run.stdout + run.stderr
    assert run.returncode == 0, log[-4000:]
    assert "submitted with SLURM jobid" in log, "no job went through sbatch"
    rows = pd.read_parquet(table)
    assert list(rows["image_id"]) == [IMAGE]
    assert rows["status"].iloc[0] == "ok", rows.iloc[0].to_dict()
    numbers = rows.select_dtypes("number").to_numpy(dtype=float)
    assert numbers.size > 0 and np.isfinite(numbers).all()
    assert non_finite_outputs(results / "features") == []
