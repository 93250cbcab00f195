"""Benchmark: the figures a change to the fit must keep, for finished runs side by side.

For each results folder: the re-render PSNR and roughness error (medians), the
fitted period within 5% of the truth, the normal-map stage's seconds (median),
the LOOCV count of each fitted feature set and of the classifier of record.
Put a run beside its reseeded twin (``config/overlays/fit_seed_1.yaml``) to read
the run-to-run noise, and beside a changed fit to read what the change did.

    .venv/bin/python workflow/benchmarks/run_figures.py RUN [RUN ...] [--out results/bench/run_figures]

Writes ``<out>/run_figures.csv`` and ``<out>/run_figures.md``.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import pandas as pd
from harness import ROOT, publish, shown


def run_row(run: Path) -> dict[str, float | str]:
    """One run's figures from its fit-accuracy, feature-set and classifier reports."""
    reports = run / "reports"
    missing = [name for name in ("fit_accuracy.csv", "feature_sets.csv", "fitted/accuracy.json") if not (reports / name).exists()]
    if missing:
        raise SystemExit(f"run_figures: error: {shown(run)} lacks reports/{', reports/'.join(missing)}; run the workflow there first")
    fits = pd.read_csv(reports / "fit_accuracy.csv")
    fits = fits[fits["status"] == "fitted"]
    periodic = fits[fits["period_error"] >= 0]
    sets = pd.read_csv(reports / "feature_sets.csv").set_index("feature_set")
    record = json.loads((reports / "fitted" / "accuracy.json").read_text())
    row: dict[str, float | str] = {
        "run": shown(run), "images": len(fits), "psnr_db": fits["psnr_db"].median(),
        "roughness_error": fits["roughness_error"].median(),
        "period_within_5pct": f"{int((periodic['period_error'] < 0.05).sum())}/{len(periodic)}",
        "normals_s": fits["normals_s"].median()}
    row |= {name: int(correct) for name, correct in sets.loc[sets["sources"] == "fitted", "correct"].items()}
    row["classifier_of_record"] = f"{record['correct']}/{record['n']}"
    return row


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="results folders (e.g. results results/seed_1)")
    parser.add_argument("--out", default="results/bench/run_figures")
    args = parser.parse_args()
    table = pd.DataFrame([run_row((ROOT / run).resolve()) for run in args.runs]).fillna("-")
    text = ("# Runs side by side: reconstruction and LOOCV figures\n\n"
            "Medians over fitted images; period within 5% over periodic images; LOOCV counts correct of the "
            "run's images (`results/reports/feature_sets.csv`, classifier of record from `reports/fitted/accuracy.json`).\n\n"
            + table.round(4).to_markdown(index=False) + "\n")
    publish((ROOT / args.out).resolve(), "run_figures", table, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
