"""Benchmark: the classifier of record with and without the photo's own column sets among its candidates.

    .venv/bin/python workflow/benchmarks/record_candidates.py RUN [RUN ...] [--name record_candidates]

For each run folder, the fitted and photo feature tables are joined as the ``classify`` rule joins
them, and the ``auto`` classifier of record is scored by the same LOOCV (a column set chosen inside
each fold by the fold's training images only) with two candidate lists: the fitted maps' sets with
``photo_structure`` and ``plus_photo`` (before 2026-11-25), and the same with the photo's radial
profile, paper features, LBP and structure + LBP added
(:data:`clothscope.classify.feature_sets.PHOTO_GROUPS`, the default since). Writes
``results/bench/<name>.{csv,md}``: per run and list, images right, and the sets the folds chose.
Nothing is chosen here.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
from class_subsets import classify_config
from harness import ROOT, publish, record_inputs, run_tables, shown

from clothscope.classify.feature_sets import PHOTO_GROUPS
from clothscope.classify.loocv import loocv

LISTS = ("without the photo's own sets", "with them (default)")


def run_rows(run: Path) -> list[dict]:
    """The classifier of record's LOOCV on one run, under each candidate list."""
    ok, tiles, everything = record_inputs(*run_tables(run), "auto")
    without = {name: columns for name, columns in everything.items() if name not in PHOTO_GROUPS}
    settings = classify_config()
    rows = []
    for label, candidates in zip(LISTS, (without, everything)):
        result = loocv(ok, [], settings["reg"], select_from=candidates, subspace=settings["subspace"], tiles=tiles)
        chosen = ", ".join(f"{name} {count}" for name, count in sorted(result.selected.items(), key=lambda kv: -kv[1]))
        rows.append({"run": shown(run), "candidates": label,
                     "correct": result.correct, "images": result.n, "accuracy": result.accuracy, "folds_chose": chosen})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="run folders (each with features/fitted and features/photo)")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--name", default="record_candidates")
    args = parser.parse_args()
    table = pd.DataFrame([row for run in args.runs for row in run_rows(ROOT / run)])
    lines = ["Classifier of record (LOOCV, column set chosen inside each fold), by its candidate list:", "",
             "| run | candidates | correct | accuracy | the folds chose |", "|---|---|---|---|---|"]
    lines += [f"| `{r.run}` | {r.candidates} | {r.correct}/{r.images} | {r.accuracy:.1%} | {r.folds_chose} |"
              for r in table.itertuples()]
    publish(args.out, args.name, table, "\n".join(lines) + "\n", float_format="%.4g")


if __name__ == "__main__":
    main()
