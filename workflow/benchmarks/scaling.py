"""Benchmark: workflow wall time on 1 and 2 cores, and fit time per image as the resolution doubles.

1. Cores: the fit stages of ``--images`` (default: two images per class) run
   from scratch with ``--cores 1`` and then ``--cores 2`` (same settings, one
   Dr.Jit thread per job, so 2 cores fit 2 images side by side).
2. Resolution: one image fitted with the working resolution (and normal-map
   texture) at 128, 256 and 512 px, one image at a time on 2 cores.
Both parts run once with an empty Dr.Jit kernel cache (HOME pointed at an empty
folder) and once warm.

    .venv/bin/python workflow/benchmarks/scaling.py [--images a,b] [--out results/bench/scaling]

Writes ``<out>/scaling.csv`` and ``<out>/scaling.md``.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
from pathlib import Path

import pandas as pd
from harness import ROOT, TWO_PER_CLASS, publish, snakemake, write_sheet


def fit_all(results: Path, cores: int, overlay: dict, sheet: Path, home: str) -> float:
    """Run every image's fit into ``results`` from scratch; returns the wall time."""
    shutil.rmtree(results / "fit", ignore_errors=True)
    results.mkdir(parents=True, exist_ok=True)
    (results / "overlay.yaml").write_text(json.dumps(overlay))
    images = pd.read_csv(sheet, sep="\t")["image_id"]
    targets = [str(results / "fit" / i / "normals") for i in images]
    return snakemake(["--configfile", "config/config.yaml", str(results / "overlay.yaml"), "--quiet", "all", "--config",
                      f"samples={sheet}", f"results={results}", "--", *targets], cores=cores, home=home)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", default=TWO_PER_CLASS)
    parser.add_argument("--resolution-image", default="canvas_red")
    parser.add_argument("--out", default="results/bench/scaling")
    args = parser.parse_args()
    out = (ROOT / args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    subset = write_sheet(args.images.split(","), out / "subset.tsv")
    single = write_sheet([args.resolution_image], out / "single.tsv")
    rows = []
    with tempfile.TemporaryDirectory() as home:
        for cache in ("cold", "warm"):
            for cores in (1, 2):
                if cache == "cold":
                    shutil.rmtree(os.path.join(home, ".drjit"), ignore_errors=True)
                wall = fit_all(out / "cores", cores, {}, subset, home)
                rows.append({"part": "cores", "cache": cache, "cores": cores, "images": len(pd.read_csv(subset, sep="\t")),
                             "resolution": 256, "wall_s": round(wall, 2)})
                print(rows[-1], flush=True)
            for resolution in (128, 256, 512):
                if cache == "cold":
                    shutil.rmtree(os.path.join(home, ".drjit"), ignore_errors=True)
                overlay = {"prepare": {"working_resolution": resolution},
                           "fit": {"threads": 2, "normals": {"resolution": resolution, "texture": resolution}}}
                wall = fit_all(out / f"res{resolution}", 2, overlay, single, home)
                rows.append({"part": "resolution", "cache": cache, "cores": 2, "images": 1, "resolution": resolution,
                             "wall_s": round(wall, 2)})
                print(rows[-1], flush=True)
    table = pd.DataFrame(rows)
    cores = table[table["part"] == "cores"].pivot(index="cache", columns="cores", values="wall_s")
    cores["speed-up 1->2 cores"] = cores[1] / cores[2]
    res = table[table["part"] == "resolution"].pivot(index="cache", columns="resolution", values="wall_s")
    text = ["# Scaling", "", f"Fit stages of {int(table['images'].max())} images, wall seconds (snakemake included):", "",
            cores.round(2).to_markdown(), "", f"One image ({args.resolution_image}) at working resolution 128/256/512 px, 2 cores:", "",
            res.round(2).to_markdown(), ""]
    publish(out, "scaling", table, "\n".join(text))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
