"""Benchmark: LOOCV accuracy on the paper's class subsets, on the design and held-out sets.

For each of the paper's experiments (5, 7 and 6 classes, :data:`clothscope.classify.paper_tables.PAPER_EXPERIMENTS`)
the images of those classes are scored three ways:

- the classifier of record, by the same LOOCV as the ``classify`` rule: the configured feature
  set (``vote`` averages every candidate set's QDA, ``auto`` chooses one inside each fold) and QDA
  subspace, on the fitted maps joined with the photo's features;
- the fitted maps alone (``auto_fitted``, ``vote_fitted``) and the photo alone (``auto_photo``), as the
  ``feature_sets`` rule scores those sets (:func:`clothscope.classify.feature_sets.compare_feature_sets`).

No setting is chosen here; the design set's figures are still optimistic (the feature groups
were designed on it), the held-out set's are not.

    .venv/bin/python workflow/benchmarks/class_subsets.py [--design results] [--holdout [results/holdout/run ...]]
        [--record-only] [--name class_subsets]

Writes ``results/bench/<name>.{csv,md}`` (``--record-only``: the classifier of record alone, in minutes). Needs each folder's
``features/{fitted,photo}/table.parquet``.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
from harness import ROOT, publish, record_inputs, record_loocv, require_tables, run_tables, shown, validated_config

from clothscope.classify.feature_sets import FEATURE_SETS, compare_feature_sets
from clothscope.classify.loocv import LoocvResult
from clothscope.classify.paper_tables import PAPER_EXPERIMENTS

#: The feature-set report's sets scored on each subset beside the classifier of record.
SOURCE_SETS = tuple(s for s in FEATURE_SETS if s.name in ("auto_fitted", "vote_fitted", "auto_photo"))


def classify_config() -> dict:
    """The validated ``classify`` section of ``config/config.yaml``."""
    return validated_config()["classify"]


def of_classes(tables: dict[str, pd.DataFrame], classes: tuple[str, ...]) -> dict[str, pd.DataFrame]:
    """Each table's rows of ``classes`` only (tile tables need no filter: a fold trains on its training images' tiles only)."""
    return {source: table[table["fabric_class"].isin(classes)] for source, table in tables.items()}


def source_scores(tables: dict[str, pd.DataFrame], tiles: dict[str, pd.DataFrame], settings: dict) -> dict[str, object]:
    """``<set>_correct``, ``<set>_n`` and ``<set>_accuracy`` of each of :data:`SOURCE_SETS` on ``tables`` (the feature-set report's LOOCV)."""
    report = compare_feature_sets(tables, settings["reg"], settings["subspace"], tiles, feature_sets=SOURCE_SETS,
                                  test_tiles=settings["test_tiles"] == "mean").set_index("feature_set")
    scores: dict[str, object] = {}
    for name in (s.name for s in SOURCE_SETS):
        scored = name in report.index and report.at[name, "status"] == "ok"
        scores[f"{name}_correct"] = int(report.at[name, "correct"]) if scored else 0
        scores[f"{name}_n"] = int(report.at[name, "n"]) if scored else 0
        scores[f"{name}_accuracy"] = float(report.at[name, "accuracy"]) if scored else float("nan")
    return scores


def folds_chose(result: LoocvResult, voting: bool) -> str:
    """What the folds chose (``auto``), or how many sets voted (``vote``)."""
    return f"{len(result.selected)} sets voted" if voting else result.selected_counts()


def scored_subsets(results: Path, label: str, settings: dict, record_only: bool = False) -> list[dict]:
    """One row per paper experiment: LOOCV of the classifier of record, and (unless ``record_only``) of the fitted
    maps and the photo alone, on those classes' images in ``results``."""
    tables, tile_tables = run_tables(results)
    table, tiles, candidates = record_inputs(tables, tile_tables, settings["feature_set"])
    rows = []
    for experiment in PAPER_EXPERIMENTS:
        subset = table[table["fabric_class"].isin(experiment.classes)]
        result = record_loocv(subset, candidates, tiles, settings)
        rows.append({"set": label, "experiment": experiment.name, "n": result.n, "correct": result.correct,
                     "accuracy": result.accuracy, "wilson_low": result.wilson_low, "wilson_high": result.wilson_high,
                     "chance": result.chance_uniform,
                     "folds_chose": folds_chose(result, settings["feature_set"] == "vote"),
                     **({} if record_only else source_scores(of_classes(tables, experiment.classes), tile_tables,
                                                             settings))})
    return rows


def held_out_label(folder: Path, folders: list[Path]) -> str:
    """``held-out``, or ``held-out (<folder>)`` when several held-out runs are scored."""
    return "held-out" if len(folders) == 1 else f"held-out ({shown(folder)})"


def _cell(accuracy: float, correct: int, n: int) -> str:
    """``95.2% (40/42)``, or ``-`` for a set that was not scored."""
    return "-" if pd.isna(accuracy) else f"{100 * accuracy:.1f}% ({correct}/{n})"


def report(frame: pd.DataFrame, settings: dict) -> str:
    """The Markdown page of the benchmark."""
    lines = ["# LOOCV on the paper's class subsets: the classifier of record, the fitted maps alone, the photo alone", "",
             f"Classifier of record: feature set `{settings['feature_set']}` (fitted maps + photo features), subspace "
             f"`{settings['subspace']}`, shrinkage `{settings['reg']}`. `auto_fitted` and `auto_photo`: the feature-set "
             "report's sets, chosen inside each fold among the fitted maps' (the photo's) own column sets; `vote_fitted`: "
             "the mean posterior of the fitted maps' column sets.",
             "Design-set figures are optimistic (the feature groups were designed on it); held-out figures are not.", "",
             "| set | experiment | classifier of record | 95% Wilson | chance | folds chose | "
             + " | ".join(s.name for s in SOURCE_SETS) + " |", "|---|---|---|---|---|---|" + "---|" * len(SOURCE_SETS)]
    for row in frame.itertuples():
        lines.append(f"| {row.set} | {row.experiment} | {_cell(row.accuracy, row.correct, row.n)} | "
                     f"{100 * row.wilson_low:.1f}-{100 * row.wilson_high:.1f}% | {100 * row.chance:.1f}% | {row.folds_chose} | "
                     + " | ".join(_cell(*(getattr(row, f"{s.name}_{k}", float("nan")) for k in ("accuracy", "correct", "n")))
                                  for s in SOURCE_SETS) + " |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--design", type=Path, default=ROOT / "results")
    parser.add_argument("--holdout", type=Path, nargs="*", default=[ROOT / "results" / "holdout" / "run"],
                        help="held-out run folders, each scored and labelled by its path (none: the design run alone)")
    parser.add_argument("--record-only", action="store_true",
                        help="score the classifier of record alone (the source sets' columns read '-')")
    parser.add_argument("--name", default="class_subsets", help="results/bench/<name>.{csv,md}")
    args = parser.parse_args()
    settings = classify_config()
    labelled = [("design", args.design)] + [(held_out_label(folder, args.holdout), folder) for folder in args.holdout]
    for _, folder in labelled:  # every run's tables are there before minutes of scoring start
        require_tables(folder)
    rows = [row for label, folder in labelled for row in scored_subsets(folder, label, settings, args.record_only)]
    frame = pd.DataFrame(rows)
    publish(ROOT / "results" / "bench", args.name, frame, report(frame, settings), float_format="%.6f")


if __name__ == "__main__":
    main()
