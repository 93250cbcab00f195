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
from pathlib import Path

import pandas as pd
from harness import ROOT, SUBSET, publish, snakemake, write_sheet

from clothscope.evaluate.accuracy import effects_comparison


def run_mode(mode: str, sheet: Path, out: Path) -> pd.DataFrame:
    results = out / mode
    configs = ["config/config.yaml"] + (["config/overlays/full_effects.yaml"] if mode == "full" else [])
    snakemake(["--configfile", *configs, "--config", f"samples={sheet}", f"results={results}", "--quiet", "all", "--",
               str(results / "reports" / "fit_accuracy.csv")])
    return pd.read_csv(results / "reports" / "fit_accuracy.csv").assign(mode=mode)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", default=SUBSET, help="comma-separated image ids, or 'all'")
    parser.add_argument("--out", default="results/bench/effects")
    args = parser.parse_args()
    out = (ROOT / args.out).resolve()
    sheet = write_sheet(args.images.split(","), out / "samples.tsv")
    table = pd.concat([run_mode(mode, sheet, out) for mode in ("planned", "full")], ignore_index=True)
    text = ("# Effects ablation: planned effects vs full effects (median over images)\n\n"
            + effects_comparison(table, "mode", "planned", "full"))
    publish(out, "effects_ablation", table, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
