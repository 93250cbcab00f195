"""Benchmark: planned effects against the forced full-effects baseline on the same images.

Runs the workflow's ``fit_accuracy`` target twice on a subset of the synthetic
set (one image per class by default): once with the default effects plan and
once with ``config/overlays/full_effects.yaml`` (prb_projective, 8 bounces, in
every stage). Compares median errors and fit time.

    .venv/bin/python workflow/benchmarks/effects_ablation.py [--images a,b|all] [--out results/bench/effects]

Writes ``<out>/effects_ablation.csv`` (per image and mode) and ``<out>/effects_ablation.md``.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

import pandas as pd

from clothscope.evaluate import effects_comparison

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_IMAGES = "broadcloth_red,canvas_navy,satin_green,chiffon_mustard,cotton_gauze_ivory,knit_jersey_charcoal,velvet_ivory"


def subset_sheet(images: list[str], target: Path) -> Path:
    sheet = pd.read_csv(ROOT / "config" / "samples.tsv", sep="\t", dtype=str, keep_default_na=False)
    if images == ["all"]:
        images = list(sheet["image_id"])
    missing = sorted(set(images) - set(sheet["image_id"]))
    if missing:
        raise SystemExit(f"effects_ablation: error: not in config/samples.tsv: {', '.join(missing)}")
    target.parent.mkdir(parents=True, exist_ok=True)
    sheet[sheet["image_id"].isin(images)].to_csv(target, sep="\t", index=False)
    return target


def run_mode(mode: str, sheet: Path, out: Path) -> pd.DataFrame:
    results = out / mode
    configs = ["config/config.yaml"] + (["config/overlays/full_effects.yaml"] if mode == "full" else [])
    subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", "--configfile", *configs, "--config",
                    f"samples={sheet}", f"results={results}", "--quiet", "all", "--", str(results / "reports" / "fit_accuracy.csv")],
                   cwd=ROOT, check=True)
    return pd.read_csv(results / "reports" / "fit_accuracy.csv").assign(mode=mode)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", default=DEFAULT_IMAGES, help="comma-separated image ids, or 'all'")
    parser.add_argument("--out", default="results/bench/effects")
    args = parser.parse_args()
    out = (ROOT / args.out).resolve()
    sheet = subset_sheet(args.images.split(","), out / "samples.tsv")
    table = pd.concat([run_mode(mode, sheet, out) for mode in ("planned", "full")], ignore_index=True)
    table.to_csv(out / "effects_ablation.csv", index=False)
    text = ("# Effects ablation: planned effects vs full effects (median over images)\n\n"
            + effects_comparison(table, "mode", "planned", "full"))
    (out / "effects_ablation.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
