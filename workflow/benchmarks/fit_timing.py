"""Benchmark: wall time and peak memory of the three fit stages per image, cold and warm kernel cache.

Runs ``snakemake`` on a few synthetic images, one image at a time with both
cores given to that image (``fit.threads = 2``). The cold pass points HOME at
an empty folder so Dr.Jit's kernel cache (``~/.drjit``) starts empty; the warm
pass reruns the same fits with the cache filled. Per-stage seconds and peak
RSS come from the rules' ``benchmark:`` files.

    .venv/bin/python workflow/benchmarks/fit_timing.py [--images a,b,c] [--out results/bench/fit_timing]

Writes ``<out>/fit_timing.csv`` and ``<out>/fit_timing.md``.
"""
from __future__ import annotations

import argparse
import os
import shutil
import tempfile
from pathlib import Path

import pandas as pd
from harness import ROOT, SUBSET, fit_costs, publish, snakemake


def run_image(image: str, results: Path, overlay: Path, home: str) -> float:
    """Fit one image through snakemake (forcing the fit stages); returns the snakemake wall time."""
    return snakemake(["--configfile", "config/config.yaml", str(overlay), "--config", f"results={results}", "--forcerun",
                      "fit_geometry", "--quiet", "all", "--", str(results / "fit" / image / "normals")], home=home, capture=True)


def stage_rows(image: str, results: Path, cache: str, snakemake_s: float) -> dict[str, float | str]:
    return {"image_id": image, "cache": cache, "snakemake_wall_s": round(snakemake_s, 2)} | fit_costs(results, image)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", default=SUBSET)
    parser.add_argument("--out", default="results/bench/fit_timing")
    args = parser.parse_args()
    out = (ROOT / args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    overlay = out / "overlay.yaml"
    overlay.write_text("fit:\n  threads: 2\n")
    rows = []
    with tempfile.TemporaryDirectory() as cold_home:
        for cache, home in (("cold", cold_home), ("warm", cold_home)):
            for image in args.images.split(","):
                if cache == "cold":  # every image starts from an empty kernel cache
                    shutil.rmtree(os.path.join(cold_home, ".drjit"), ignore_errors=True)
                wall = run_image(image, out / "runs", overlay, home)
                rows.append(stage_rows(image, out / "runs", cache, wall))
                print(rows[-1], flush=True)
    table = pd.DataFrame(rows)
    summary = table.groupby("cache")[["geometry_s", "material_s", "normals_s", "fit_s", "snakemake_wall_s", "max_rss_mb"]]
    text = ["# Fit time per 256 px image (2 cores, one image at a time)", "",
            "Median over images:", "", summary.median().round(2).to_markdown(), "", "Maximum over images:", "",
            summary.max().round(2).to_markdown(), ""]
    publish(out, "fit_timing", table, "\n".join(text))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
