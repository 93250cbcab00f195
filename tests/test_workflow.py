"""The Snakemake workflow as a new user meets it: dry run and lint on a fresh clone, and a run on broken files."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
import yaml
from conftest import FILE_PROBLEMS, broken_and_valid_files, job_counts, run_snakemake


def test_dry_run_plans_one_job_per_image_per_stage(fresh_clone):
    n_images = len(pd.read_csv(fresh_clone / "config" / "samples.tsv", sep="\t", dtype=str))
    result = run_snakemake(fresh_clone, "-n", "--cores", "2")
    assert result.returncode == 0, result.stderr[-2000:]
    counts = job_counts(result.stdout)
    assert counts["prepare"] == n_images and counts["rejection_report"] == 1 and counts["all"] == 1
    # default normal_source is fitted: every image is fitted, then gets a feature row from its fitted maps,
    # its photo alone and its ground truth (the feature-set report compares the three)
    for rule in ("fit_geometry", "fit_material", "fit_normals"):
        assert counts.get(rule) == n_images, rule
    assert counts["features"] == 3 * n_images and counts["feature_table"] == 3
    assert counts["classify"] == counts["paper_tables"] == counts["fit_accuracy"] == 1
    assert counts["feature_sets"] == counts["spectra_diagnosis"] == 1
    assert "sweep" not in counts


def test_dry_run_in_truth_mode_fits_nothing(fresh_clone):
    n_images = len(pd.read_csv(fresh_clone / "config" / "samples.tsv", sep="\t", dtype=str))
    result = run_snakemake(fresh_clone, "-n", "--cores", "2", "--config", "features={normal_source: truth}")
    assert result.returncode == 0, result.stderr[-2000:]
    counts = job_counts(result.stdout)
    # truth and photo rows (no diagnosis: it compares with fitted maps)
    assert counts["features"] == 2 * n_images and not any(rule.startswith("fit_") for rule in counts)
    assert "spectra_diagnosis" not in counts
    assert "results/features/truth/table.parquet" in result.stdout


def fit_runtimes(stdout: str) -> set[int]:
    """The ``runtime`` resource (minutes) of every fit job a dry run lists."""
    blocks = [block for block in stdout.split("rule ")[1:] if block.startswith(("fit_geometry:", "fit_material:", "fit_normals:"))]
    return {int(line.split("runtime=")[1].split(",")[0]) for block in blocks for line in block.splitlines() if "runtime=" in line}


def test_fit_jobs_take_the_presets_time_limit(fresh_clone, tmp_path):
    """A cluster kills a job at its runtime: the paper preset's fit jobs ask for its longer fit.runtime."""
    sheet = tmp_path / "s.tsv"
    sheet.write_text("image_id\tpath\na\tdata/synthetic/canvas/canvas_red.png\n")
    schema = yaml.safe_load((fresh_clone / "src" / "clothscope" / "core" / "schemas" / "config.schema.yaml").read_text())
    default = schema["properties"]["fit"]["properties"]["runtime"]["default"]
    paper = yaml.safe_load((fresh_clone / "config" / "presets" / "paper.yaml").read_text())["fit"]["runtime"]
    limits = {}
    for preset in ("default", "paper"):
        result = run_snakemake(fresh_clone, "-n", "--cores", "1", "--config", f"samples={sheet}", f"preset={preset}",
                               f"results={tmp_path / preset}")
        assert result.returncode == 0, result.stderr[-2000:]
        limits[preset] = fit_runtimes(result.stdout)
    assert limits == {"default": {default}, "paper": {paper}} and paper > default


def test_lint_is_clean(fresh_clone):
    result = run_snakemake(fresh_clone, "--lint")
    assert result.returncode == 0 and "Congratulations" in result.stdout + result.stderr, result.stdout[-3000:]


def test_snakefmt_is_clean(fresh_clone):
    result = subprocess.run([sys.executable, "-m", "snakefmt", "--check", "."], cwd=fresh_clone, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr[-3000:]


def test_bad_sample_sheet_stops_before_any_job_with_one_line(fresh_clone, tmp_path):
    sheet = tmp_path / "s.tsv"
    sheet.write_text("image_id\tpath\na\tx.png\na\ty.png\n")
    result = run_snakemake(fresh_clone, "-n", "--cores", "1", "--config", f"samples={sheet}")
    assert result.returncode != 0
    assert f"clothscope: error: {sheet}: duplicate image_id(s): a" in result.stderr


def test_unreadable_files_are_planned_as_rejections_not_errors(fresh_clone, tmp_path):
    """A row naming a directory, a symlink loop or a missing file plans its prepare job (which rejects it), like any other."""
    files = broken_and_valid_files(tmp_path / "photos")
    sheet = tmp_path / "samples.tsv"
    sheet.write_text("image_id\tpath\tfabric_class\n" + "".join(f"{stem}\t{path}\twool\n" for stem, (path, _) in files.items()))
    result = run_snakemake(fresh_clone, "-n", "--cores", "1", "--config", f"samples={sheet}", f"results={tmp_path / 'results'}")
    assert result.returncode == 0, result.stderr[-2000:]
    counts = job_counts(result.stdout)
    assert counts["prepare"] == len(files)
    assert "paper_tables" not in counts, "the paper tables are for sheets with the paper's classes"


@pytest.mark.slow
def test_broken_files_are_reported_and_valid_ones_proceed(fresh_clone, tmp_path):
    files = broken_and_valid_files(tmp_path / "photos")
    sheet = tmp_path / "samples.tsv"
    sheet.write_text("image_id\tpath\n" + "".join(f"{stem}\t{path}\n" for stem, (path, _) in files.items()))
    results = tmp_path / "results"
    result = run_snakemake(fresh_clone, "--cores", "2", "--config", f"samples={sheet}", f"results={results}")
    assert result.returncode == 0, result.stderr[-3000:]
    rejected = pd.read_csv(results / "reports" / "rejected.tsv", sep="\t")
    bad = {stem for stem, (_, valid) in files.items() if not valid}
    assert set(rejected["image_id"]) == bad
    for _, row in rejected.iterrows():
        assert row["path"] in row["reason"] and "\n" not in row["reason"]
        assert FILE_PROBLEMS.get(row["image_id"], "") in row["reason"], row["reason"]
    for stem, (_, valid) in files.items():
        if valid:
            assert (results / "prepared" / stem / "image.exr").is_file(), stem


#: fit settings small enough for a whole fit in seconds (the kill test only needs the stages to run)
TINY_FIT = {"geometry": {"resolution": 32, "spp": 2, "iterations": 6}, "material": {"resolution": 32, "spp": 1, "iterations": 4},
            "normals": {"resolution": 64, "texture": 64, "spp": 2, "spp_grad": 1, "iterations": 4, "joint_iterations": 6}}


def fitted_outputs(results: Path) -> dict[str, bytes]:
    """The bytes of the fitted maps and the feature values of a one-image run (not its timings)."""
    normals = results / "fit" / "canvas_red" / "normals"
    table = pd.read_parquet(results / "features" / "fitted" / "table.parquet")
    features = table.select_dtypes("number").to_numpy(dtype=float).tobytes()
    return {"normal.exr": (normals / "normal.exr").read_bytes(), "height.exr": (normals / "height.exr").read_bytes(),
            "features": features}


@pytest.mark.slow
def test_killed_run_reruns_to_the_same_outputs(fresh_clone, tmp_path):
    """SIGKILL the workflow mid-fit, unlock, rerun: the outputs equal an uninterrupted run's, bit for bit, no temporaries left."""
    sheet = tmp_path / "samples.tsv"
    sheet.write_text(f"image_id\tpath\tfabric_class\ncanvas_red\t{fresh_clone / 'data/synthetic/canvas/canvas_red.png'}\tcanvas\n")

    def args(results: Path) -> list[str]:
        config = tmp_path / f"{results.name}.yaml"
        config.write_text(yaml.safe_dump({"samples": str(sheet), "results": str(results), "fit": TINY_FIT}))
        return ["--cores", "1", str(results / "features" / "fitted" / "table.parquet"), "--configfile", str(config)]

    clean, killed = tmp_path / "clean", tmp_path / "killed"
    assert run_snakemake(fresh_clone, *args(clean)).returncode == 0
    process = subprocess.Popen([sys.executable, "-m", "snakemake", *args(killed)], cwd=fresh_clone, start_new_session=True,
                               stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    started = time.monotonic()
    while not (killed / "logs" / "fit_normals" / "canvas_red.log").exists() and time.monotonic() - started < 300:
        time.sleep(0.2)
    time.sleep(1.0)
    os.killpg(process.pid, signal.SIGKILL)
    process.wait()
    assert not (killed / "features" / "fitted" / "table.parquet").exists(), "the kill came too late to test anything"
    assert run_snakemake(fresh_clone, "--unlock", *args(killed)[2:]).returncode == 0
    rerun = run_snakemake(fresh_clone, *args(killed))
    assert rerun.returncode == 0, rerun.stderr[-3000:]
    assert fitted_outputs(killed) == fitted_outputs(clean)
    assert not [p for p in killed.rglob("*") if ".tmp" in p.name], "stale temporaries"
