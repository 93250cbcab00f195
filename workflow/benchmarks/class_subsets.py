"""Benchmark: the classifier of record's LOOCV accuracy on the paper's class subsets, on the design and held-out sets.

For each of the paper's experiments (5, 7 and 6 classes, :data:`clothscope.classify.paper_tables.PAPER_EXPERIMENTS`)
the images of those classes are scored by the same LOOCV as the ``classify`` rule: the
configured feature set (``auto`` chooses inside each fold) and QDA subspace, on the fitted maps
joined with the photo's features. No setting is chosen here; the design set's figures are
still optimistic (the feature groups were designed on it), the held-out set's are not.

    .venv/bin/python workflow/benchmarks/class_subsets.py [--design results] [--holdout results/holdout/run ...]

Writes ``results/bench/class_subsets.{csv,md}``. Needs each folder's
``features/{fitted,photo}/table.parquet``.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
from harness import ROOT, publish, record_inputs, record_loocv, run_tables, shown, validated_config

from clothscope.classify.paper_tables import PAPER_EXPERIMENTS


def classify_config() -> dict:
    """The validated ``classify`` section of ``config/config.yaml``."""
    return validated_config()["classify"]


def scored_subsets(results: Path, label: str, settings: dict) -> list[dict]:
    """One row per paper experiment: LOOCV of the classifier of record on those classes' images in ``results``."""
    table, tiles, candidates = record_inputs(*run_tables(results), settings["feature_set"])
    rows = []
    for experiment in PAPER_EXPERIMENTS:
        subset = table[table["fabric_class"].isin(experiment.classes)]
        result = record_loocv(subset, candidates, tiles, settings)
        rows.append({"set": label, "experiment": experiment.name, "n": result.n, "correct": result.correct,
                     "accuracy": result.accuracy, "wilson_low": result.wilson_low, "wilson_high": result.wilson_high,
                     "chance": result.chance_uniform,
                     "folds_chose": ", ".join(f"{k} {v}" for k, v in sorted(result.selected.items(), key=lambda kv: -kv[1]))})
    return rows


def held_out_label(folder: Path, folders: list[Path]) -> str:
    """``held-out``, or ``held-out (<folder>)`` when several held-out runs are scored."""
    return "held-out" if len(folders) == 1 else f"held-out ({shown(folder)})"


def report(frame: pd.DataFrame, settings: dict) -> str:
    """The Markdown page of the benchmark."""
    lines = ["# Classifier of record on the paper's class subsets (LOOCV, fitted maps + photo features)", "",
             f"Feature set `{settings['feature_set']}`, subspace `{settings['subspace']}`, shrinkage `{settings['reg']}`.",
             "Design-set figures are optimistic (the feature groups were designed on it); held-out figures are not.", "",
             "| set | experiment | accuracy | 95% Wilson | chance | folds chose |", "|---|---|---|---|---|---|"]
    for row in frame.itertuples():
        lines.append(f"| {row.set} | {row.experiment} | {100 * row.accuracy:.1f}% ({row.correct}/{row.n}) | "
                     f"{100 * row.wilson_low:.1f}-{100 * row.wilson_high:.1f}% | {100 * row.chance:.1f}% | {row.folds_chose} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--design", type=Path, default=ROOT / "results")
    parser.add_argument("--holdout", type=Path, nargs="+", default=[ROOT / "results" / "holdout" / "run"],
                        help="held-out run folders, each scored and labelled by its path")
    args = parser.parse_args()
    settings = classify_config()
    labelled = [("design", args.design)] + [(held_out_label(folder, args.holdout), folder) for folder in args.holdout]
    rows = [row for label, folder in labelled for row in scored_subsets(folder, label, settings)]
    frame = pd.DataFrame(rows)
    publish(ROOT / "results" / "bench", "class_subsets", frame, report(frame, settings), float_format="%.6f")


if __name__ == "__main__":
    main()
