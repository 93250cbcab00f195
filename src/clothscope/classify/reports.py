"""Classifier reports: LOOCV predictions, confusion matrices and figures, per-class metrics, the summary JSON and Markdown."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from clothscope.classify.loocv import LoocvResult
from clothscope.classify.outputs import ACCURACY_FILE, CONFUSION_CSV_FILE, CONFUSION_FILE, PER_CLASS_FILE, PREDICTIONS_FILE
from clothscope.classify.rows import POSTERIOR_PREFIX, posterior_column
from clothscope.core.atomic import write_json, write_text
from clothscope.core.figures import new_figure, save_png


def _require_finite(frame: pd.DataFrame, name: str) -> None:
    numeric = frame.select_dtypes(include="number")
    if numeric.size and not np.isfinite(numeric.to_numpy(dtype=float)).all():
        raise ValueError(f"refusing to write {name}: it holds non-finite numbers")


def _write_csv(target: Path, frame: pd.DataFrame, index: bool = False) -> None:
    _require_finite(frame, target.name)
    write_text(target, frame.to_csv(index=index, lineterminator="\n"))


def prediction_table(result: LoocvResult, predictions_for_queries: pd.DataFrame | None = None) -> pd.DataFrame:
    """LOOCV predictions and query predictions in one table (``split`` = ``loocv`` / ``query``).

    Posterior columns cover the union of both sets of classes; a class
    missing from one model has posterior 0 there.
    """
    queries = predictions_for_queries if predictions_for_queries is not None else pd.DataFrame(columns=["image_id", "predicted_class"])
    query_classes = [c[len(POSTERIOR_PREFIX) :] for c in queries.columns if c.startswith(POSTERIOR_PREFIX)]
    classes = sorted(set(result.classes) | set(query_classes))
    p_columns = [posterior_column(c) for c in classes]
    loo = result.predictions.copy()
    loo["split"] = "loocv"
    q = queries.copy()
    q["true_class"] = ""
    q["split"] = "query"
    frames = []
    for frame in (loo, q):
        for column in p_columns:
            if column not in frame.columns:
                frame[column] = 0.0
        if len(frame):
            frames.append(frame[["image_id", "true_class", "predicted_class", *p_columns, "split"]])
    table = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame(columns=["image_id", "true_class", "predicted_class", *p_columns, "split"])
    table[p_columns] = table[p_columns].astype(float)
    return table


def _confusion_figure(confusion: pd.DataFrame, title: str, target: Path) -> None:
    """The confusion matrix as a PNG (counts in the cells), written atomically."""
    counts = confusion.to_numpy()
    k = len(confusion)
    side = max(4.0, 0.75 * k + 2.5)
    fig = new_figure(side + 1.0, side)
    ax = fig.add_subplot(1, 1, 1)
    image = ax.imshow(counts, cmap="Blues", vmin=0, vmax=max(1, int(counts.max())))
    fig.colorbar(image, ax=ax, fraction=0.046, pad=0.04, label="images")
    ax.set_xticks(range(k), [str(c) for c in confusion.columns], rotation=45, ha="right")
    ax.set_yticks(range(k), [str(c) for c in confusion.index])
    ax.set_xlabel("predicted class")
    ax.set_ylabel("true class")
    ax.set_title(title)
    threshold = counts.max() / 2 if counts.max() else 1
    for i in range(k):
        for j in range(k):
            ax.text(j, i, str(int(counts[i, j])), ha="center", va="center", color="white" if counts[i, j] > threshold else "black")
    fig.tight_layout()
    save_png(fig, target, dpi=120)


def write_reports(
    result: LoocvResult,
    predictions_for_queries: pd.DataFrame | None,
    out_dir: str | os.PathLike[str],
    title: str,
) -> dict[str, Path]:
    """Write the classification reports into ``out_dir``, each file atomically.

    Files: ``accuracy.json``, ``confusion.csv``, ``confusion.png``,
    ``per_class.csv`` and ``predictions.csv`` (LOOCV rows and query rows,
    ``split`` column ``loocv`` / ``query``).

    Returns
    -------
    dict
        Report name to path.
    """
    out = Path(out_dir)
    paths = {name: out / name for name in (ACCURACY_FILE, CONFUSION_CSV_FILE, CONFUSION_FILE, PER_CLASS_FILE, PREDICTIONS_FILE)}
    predictions = prediction_table(result, predictions_for_queries)
    accuracy = {
        "title": title,
        "accuracy": float(result.accuracy),
        "correct": int(result.correct),
        "n": int(result.n),
        "confidence": 0.95,
        "wilson_low": float(result.wilson_low),
        "wilson_high": float(result.wilson_high),
        "chance_uniform": float(result.chance_uniform),
        "chance_majority": float(result.chance_majority),
        "majority_class": result.majority_class,
        "classes": list(result.classes),
        "feature_columns": list(result.feature_columns),
        "dropped_columns": list(result.dropped_columns),
        "excluded_classes": {c: list(ids) for c, ids in result.excluded.items()},
        "n_queries": int((predictions["split"] == "query").sum()),
        "reg": result.reg,
        "subspace": result.subspace,
        "method": "leave-one-out cross-validation of QDA (StandardScaler + shrunk, floored class covariances"
                  + (", in the discriminant subspace of each fold's training images)" if result.subspace == "discriminant" else ")"),
        "notes": list(result.notes),
        "selected_feature_sets": dict(result.selected),
    }
    write_json(paths[ACCURACY_FILE], accuracy)
    _write_csv(paths[CONFUSION_CSV_FILE], result.confusion, index=True)
    _confusion_figure(result.confusion, title, paths[CONFUSION_FILE])
    _write_csv(paths[PER_CLASS_FILE], result.per_class)
    _write_csv(paths[PREDICTIONS_FILE], predictions)
    return paths
