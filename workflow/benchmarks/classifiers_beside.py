"""Benchmark: other scikit-learn classifiers beside QDA, on the same feature sets and images.

    .venv/bin/python workflow/benchmarks/classifiers_beside.py RUN [RUN ...] [--name classifiers_beside]

QDA stays the classifier of record; this asks whether it, rather than the features, limits a
set. For each run folder and each fixed feature set of ``feature_sets.md`` (not the ``auto``
ones, whose choice is QDA's), every classifier of :func:`classifiers` is scored by the same
leave-one-out cross-validation on the same images (those usable in every source), on whole
images only (no tiles), each with its scikit-learn defaults (nothing is tuned, so nothing is
chosen by these scores). QDA is the workflow's (:func:`clothscope.classify.qda.make_qda`, with
the configured shrinkage and subspace). Writes ``results/bench/<name>.{csv,md}``: images right
per run, set and classifier.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from class_subsets import classify_config
from harness import run_tables, runs_report, shown
from sklearn.base import ClassifierMixin
from sklearn.discriminant_analysis import LinearDiscriminantAnalysis
from sklearn.linear_model import LogisticRegression
from sklearn.model_selection import LeaveOneOut, cross_val_predict
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.svm import SVC

from clothscope.classify.feature_sets import FEATURE_SETS, common_images, joined_features
from clothscope.classify.qda import make_qda
from clothscope.classify.rows import MIN_LOOCV_PER_CLASS, labelled_data


def classifiers(settings: dict) -> dict[str, ClassifierMixin]:
    """The classifier of record (QDA as configured) and three others with scikit-learn's defaults, each standardised."""
    return {
        "QDA (the record's)": make_qda(settings["reg"], subspace=settings["subspace"]),
        "LDA, Ledoit-Wolf": make_pipeline(StandardScaler(), LinearDiscriminantAnalysis(solver="lsqr", shrinkage="auto")),
        "logistic regression": make_pipeline(StandardScaler(), LogisticRegression(max_iter=5000)),
        "SVM, RBF kernel": make_pipeline(StandardScaler(), SVC()),
    }


def run_rows(run: Path, settings: dict) -> list[dict]:
    """Images right per fixed feature set and classifier on one run."""
    sources = tuple(s for s in ("fitted", "photo", "truth") if (run / "features" / s / "table.parquet").is_file())
    tables = run_tables(run, sources)[0]
    images = common_images(tables)
    rows = []
    for feature_set in FEATURE_SETS:
        if not set(feature_set.sources) <= set(sources) or any(group == "auto" for _, group in feature_set.parts):
            continue
        frame, columns = joined_features(feature_set, tables, images)
        _, _, _, used, _, X, y = labelled_data(frame, columns, MIN_LOOCV_PER_CLASS, "comparing classifiers")
        for name, model in classifiers(settings).items():
            predicted = cross_val_predict(model, X, y, cv=LeaveOneOut())
            rows.append({"run": shown(run), "feature_set": feature_set.name, "features": len(used),
                         "classifier": name, "correct": int(np.sum(predicted == y)), "images": len(y)})
    return rows


def markdown(table: pd.DataFrame) -> str:
    """One table per run: feature sets down, classifiers across, images right."""
    parts = ["LOOCV on whole images (no tiles), same images for every set and classifier; scikit-learn defaults, "
             "nothing tuned. QDA is the classifier of record; the others are reported beside it, never instead.", ""]
    for run, part in table.groupby("run", sort=False):
        cells = part.assign(cell=part["correct"].astype(str) + "/" + part["images"].astype(str))
        wide = cells.pivot(index="feature_set", columns="classifier", values="cell")
        wide = wide.loc[list(dict.fromkeys(part["feature_set"])), list(dict.fromkeys(part["classifier"]))]
        parts += [f"`{run}`:", "", wide.reset_index().to_markdown(index=False), ""]
    return "\n".join(parts)


def main() -> None:
    settings = classify_config()
    runs_report(__doc__, "classifiers_beside", "run folders (each with features/<source>/table.parquet)", lambda run: run_rows(run, settings), markdown)


if __name__ == "__main__":
    main()
