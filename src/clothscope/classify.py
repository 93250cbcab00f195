"""Fabric classification: QDA on per-image features, scored by leave-one-out cross-validation.

The input is a *feature table*: a DataFrame with ``image_id``, ``fabric_class``
(empty, ``None`` or NaN marks an unlabelled query image) and numeric feature
columns. Only labelled rows are ever used to fit or score a model; queries
are classified by a model trained on all labelled rows (paper sections 3.4
and 4.1).

Small classes are the norm here (the paper has six images per class), so the
classifier is a standardised, shrunk QDA (:func:`make_qda`) whose per-class
covariance eigenvalues are floored, which keeps every posterior finite even
for a class of two images or a feature that is constant within a class.
"""
from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass, field
from numbers import Real
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from sklearn.discriminant_analysis import LinearDiscriminantAnalysis, QuadraticDiscriminantAnalysis
from sklearn.model_selection import StratifiedKFold
from sklearn.pipeline import Pipeline
from sklearn.preprocessing import StandardScaler
from sklearn.utils._param_validation import Interval

from .atomic import write_json, write_text, write_with
from .qda_model import QdaModel, QdaParameters

#: Smallest per-class variance along any principal axis, in units of the
#: (training-set) standardised features. Keeps a class whose images agree
#: exactly on some feature from getting an infinitely narrow Gaussian.
VAR_FLOOR = 1e-3
#: A class needs this many labelled images to be fitted (QDA needs a covariance).
MIN_TRAIN_PER_CLASS = 2
#: ... and this many to be scored by LOOCV (every training fold still has 2).
MIN_LOOCV_PER_CLASS = 3
#: Prefix of the posterior columns in prediction tables.
POSTERIOR_PREFIX = "p_"
#: Feature spaces QDA can be fitted in: the standardised features as they are
#: (the paper's), or their discriminant subspace (see :func:`make_qda`).
SUBSPACES = ("none", "discriminant")


class FlooredQDA(QuadraticDiscriminantAnalysis):
    """QDA whose per-class covariance eigenvalues are at least ``var_floor``.

    Identical to scikit-learn's ``QuadraticDiscriminantAnalysis`` with
    ``solver="eigen"`` (shrinkage, priors and all), except that after the
    shrunk class covariance is decomposed its eigenvalues are clipped from
    below. Without the floor, Ledoit-Wolf shrinkage of a 2-image class is
    ~0 (rank-1 covariance) and a class constant in every feature has a zero
    covariance; both make ``fit`` raise or the posteriors NaN.

    Parameters
    ----------
    var_floor
        Lower bound of each eigenvalue; must exceed ``tol``.
    """

    _parameter_constraints: dict = {
        **QuadraticDiscriminantAnalysis._parameter_constraints,
        "var_floor": [Interval(Real, 0, None, closed="neither")],
    }

    def __init__(
        self,
        *,
        solver: str = "eigen",
        shrinkage: str | float | None = None,
        priors: Any = None,
        reg_param: float = 0.0,
        store_covariance: bool = False,
        tol: float = 1.0e-4,
        covariance_estimator: Any = None,
        var_floor: float = VAR_FLOOR,
    ) -> None:
        super().__init__(
            solver=solver,
            shrinkage=shrinkage,
            priors=priors,
            reg_param=reg_param,
            store_covariance=store_covariance,
            tol=tol,
            covariance_estimator=covariance_estimator,
        )
        self.var_floor = var_floor

    def fit(self, X: Any, y: Any) -> FlooredQDA:
        """Fit as QDA with ``solver="eigen"``; see the class docstring."""
        if self.solver != "eigen":
            raise ValueError(f"FlooredQDA needs solver='eigen', got {self.solver!r}")
        if not self.var_floor > self.tol:
            raise ValueError(f"var_floor ({self.var_floor}) must exceed tol ({self.tol})")
        return super().fit(X, y)

    def _solve_eigen(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        scaling, rotation, _ = super()._solve_eigen(X)
        scaling = np.maximum(np.nan_to_num(scaling, nan=0.0), self.var_floor)
        cov = (rotation * scaling) @ rotation.T
        return scaling, rotation, cov


@dataclass
class LoocvResult:
    """Leave-one-out cross-validation of QDA over the labelled rows.

    ``predictions`` has columns ``image_id``, ``true_class``,
    ``predicted_class`` and one ``p_<class>`` per class of ``classes``.
    ``confusion`` is indexed by true class (rows) and predicted class
    (columns). ``per_class`` has ``class``, ``support``, ``predicted``,
    ``correct``, ``precision`` and ``recall``. ``excluded`` maps a class
    with too few labelled images for LOOCV to its image ids.
    """

    classes: list[str]
    feature_columns: list[str]
    dropped_columns: list[str]
    reg: str | float
    subspace: str
    predictions: pd.DataFrame
    correct: int
    n: int
    accuracy: float
    wilson_low: float
    wilson_high: float
    chance_uniform: float
    chance_majority: float
    majority_class: str
    confusion: pd.DataFrame
    per_class: pd.DataFrame
    excluded: dict[str, list[str]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    selected: dict[str, int] = field(default_factory=dict)


# --------------------------------------------------------------------------- helpers


def wilson_interval(successes: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion.

    Parameters
    ----------
    successes, n
        Successes out of ``n`` trials; ``0 <= successes <= n``, ``n > 0``.
    z
        Standard-normal quantile (1.96: 95 %).

    Returns
    -------
    tuple of float
        ``(low, high)``, within [0, 1].
    """
    if n <= 0:
        raise ValueError(f"wilson_interval needs n > 0 trials, got n={n}")
    if not 0 <= successes <= n:
        raise ValueError(f"wilson_interval needs 0 <= successes <= n, got successes={successes}, n={n}")
    if not (math.isfinite(z) and z > 0):
        raise ValueError(f"wilson_interval needs a finite z > 0, got {z}")
    p = successes / n
    z2 = z * z
    denom = 1.0 + z2 / n
    centre = (p + z2 / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


def _check_reg(reg: float | str) -> float | str:
    if isinstance(reg, str):
        if reg != "auto":
            raise ValueError(f"reg must be 'auto' (Ledoit-Wolf) or a float in [0, 1], got {reg!r}")
        return reg
    if isinstance(reg, bool) or not isinstance(reg, Real) or not (0.0 <= float(reg) <= 1.0):
        raise ValueError(f"reg must be 'auto' (Ledoit-Wolf) or a float in [0, 1], got {reg!r}")
    return float(reg)


def _check_subspace(subspace: str) -> str:
    if subspace not in SUBSPACES:
        raise ValueError(f"subspace must be one of {', '.join(SUBSPACES)}, got {subspace!r}")
    return subspace


def make_qda(reg: float | str = "auto", *, var_floor: float = VAR_FLOOR, subspace: str = "none") -> Pipeline:
    """The classifier: standardise features, optionally project them, then shrunk QDA with floored class covariances.

    Parameters
    ----------
    reg
        Covariance shrinkage: ``"auto"`` (Ledoit-Wolf) or a float in [0, 1].
    var_floor
        Lower bound of each class-covariance eigenvalue, in standardised units.
    subspace
        ``"none"``: QDA on the standardised features (the paper's classifier).
        ``"discriminant"``: QDA on the at most ``n_classes - 1`` Fisher
        discriminant directions of the training images (shrunk LDA,
        Ledoit-Wolf), fitted inside the pipeline so that a LOOCV fold never
        sees its held-out image. With a handful of images per class and tens
        of features, each class covariance is then estimated in a few
        dimensions instead of tens.

    Returns
    -------
    sklearn.pipeline.Pipeline
        Steps ``scale`` (StandardScaler), ``project`` (with
        ``subspace="discriminant"``) and ``qda`` (:class:`FlooredQDA`,
        ``solver="eigen"``, ``shrinkage=reg``, ``priors=None``: class
        proportions of the training data).
    """
    reg = _check_reg(reg)
    subspace = _check_subspace(subspace)
    if not (math.isfinite(var_floor) and var_floor > 0):
        raise ValueError(f"var_floor must be a finite number > 0, got {var_floor}")
    qda = FlooredQDA(solver="eigen", shrinkage=reg, priors=None, var_floor=var_floor, tol=min(1e-4, var_floor / 2))
    steps: list[tuple[str, Any]] = [("scale", StandardScaler())]
    if subspace == "discriminant":
        steps.append(("project", LinearDiscriminantAnalysis(solver="eigen", shrinkage="auto")))
    return Pipeline([*steps, ("qda", qda)])


def label_mask(table: pd.DataFrame) -> pd.Series:
    """True for rows with a fabric class; empty strings, ``None`` and NaN are queries."""
    if "fabric_class" not in table.columns:
        raise ValueError("feature table has no 'fabric_class' column")
    labels = table["fabric_class"]
    return labels.notna() & (labels.astype(str).str.strip() != "")


def split_labelled(table: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The labelled rows (``fabric_class`` stripped) and the query rows of a feature table."""
    mask = label_mask(table)
    labelled = table[mask].copy()
    labelled["fabric_class"] = labelled["fabric_class"].astype(str).str.strip()
    return labelled, table[~mask].copy()


def _check_table(table: pd.DataFrame, feature_columns: list[str]) -> list[str]:
    """Validate the table's shape; return the feature columns as a list."""
    if not isinstance(table, pd.DataFrame):
        raise ValueError(f"feature table must be a pandas DataFrame, got {type(table).__name__}")
    columns = list(feature_columns)
    if not columns:
        raise ValueError("no feature columns given")
    if len(set(columns)) != len(columns):
        raise ValueError(f"feature columns repeat: {columns}")
    missing = [c for c in ["image_id", "fabric_class", *columns] if c not in table.columns]
    if missing:
        raise ValueError(f"feature table lacks column(s) {', '.join(map(repr, missing))}")
    ids = table["image_id"].astype(str)
    duplicated = ids[ids.duplicated()].unique().tolist()
    if duplicated:
        raise ValueError(f"feature table has duplicate image_id(s): {', '.join(duplicated)}")
    return columns


def _features(rows: pd.DataFrame, columns: list[str], what: str) -> np.ndarray:
    """Float feature matrix of ``rows``; ValueError naming non-numeric columns or non-finite rows."""
    try:
        X = rows[columns].apply(pd.to_numeric, errors="raise").to_numpy(dtype=float)
    except (ValueError, TypeError) as err:
        raise ValueError(f"{what}: feature columns must be numeric: {err}") from None
    bad = ~np.isfinite(X).all(axis=1)
    if bad.any():
        ids = rows["image_id"].astype(str).to_numpy()[bad]
        raise ValueError(f"{what}: non-finite feature value(s) in image(s) {', '.join(ids[:10])}{' ...' if len(ids) > 10 else ''}")
    return X


def _drop_constant(X: np.ndarray, columns: list[str]) -> tuple[list[str], list[str], list[str]]:
    """Columns that vary over the labelled rows, the constant ones, and notes."""
    spread = X.max(axis=0) - X.min(axis=0) if len(X) else np.zeros(len(columns))
    scale = np.maximum(np.abs(X).max(axis=0), 1.0) if len(X) else np.ones(len(columns))
    constant = spread <= 1e-12 * scale
    kept = [c for c, k in zip(columns, constant) if not k]
    dropped = [c for c, k in zip(columns, constant) if k]
    notes = [f"feature {c!r} is constant over the labelled images and was dropped" for c in dropped]
    if not kept:
        raise ValueError(f"every feature column is constant over the labelled images: {', '.join(columns)}")
    return kept, dropped, notes


def _select_classes(labelled: pd.DataFrame, minimum: int, purpose: str) -> tuple[pd.DataFrame, dict[str, list[str]], list[str]]:
    """Keep classes with at least ``minimum`` labelled images; the others are excluded with a note."""
    counts = labelled["fabric_class"].value_counts()
    small = sorted(c for c, k in counts.items() if k < minimum)
    excluded = {c: sorted(labelled.loc[labelled["fabric_class"] == c, "image_id"].astype(str)) for c in small}
    notes = [
        f"warning: class {c!r} has {int(counts[c])} labelled image(s); {purpose} needs at least {minimum}, "
        f"so it is excluded ({', '.join(excluded[c])})"
        for c in small
    ]
    kept = labelled[~labelled["fabric_class"].isin(small)]
    classes = sorted(kept["fabric_class"].unique())
    if len(classes) < 2:
        detail = f"; excluded for too few images: {', '.join(small)}" if small else ""
        raise ValueError(
            f"{purpose} needs at least 2 fabric classes with >= {minimum} labelled images each, "
            f"got {len(classes)} ({', '.join(classes) or 'none'}){detail}"
        )
    return kept, excluded, notes


def _fit(reg: float | str, X: np.ndarray, y: np.ndarray, notes: list[str], subspace: str = "none") -> Pipeline:
    """Fit :func:`make_qda`; warnings become notes (each once)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = make_qda(reg, subspace=subspace).fit(X, y)
    for w in caught:
        message = f"scikit-learn warning: {w.message}"
        if message not in notes:
            notes.append(message)
    return model


def _posteriors(pipeline: Pipeline, X: np.ndarray, ids: list[str]) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        proba = pipeline.predict_proba(X)
    return _check_posteriors(proba, ids)


def _check_posteriors(proba: np.ndarray, ids: list[str]) -> np.ndarray:
    bad = ~np.isfinite(proba).all(axis=1)
    if bad.any():
        raise ValueError(f"posteriors are not finite for image(s) {', '.join(np.asarray(ids)[bad])}: feature values too extreme")
    return proba


def posterior_column(fabric_class: str) -> str:
    """Name of the posterior column of a class: ``p_<class>``."""
    return f"{POSTERIOR_PREFIX}{fabric_class}"


# --------------------------------------------------------------------------- LOOCV


def _labelled_data(table: pd.DataFrame, feature_columns: list[str], min_per_class: int,
                   purpose: str) -> tuple[pd.DataFrame, dict, list[str], list[str], list[str], np.ndarray, np.ndarray]:
    """Labelled rows of classes with enough images, their usable (non-constant) features and labels.

    Returns labelled rows, excluded classes, notes, used and dropped columns, X and y.
    """
    columns = _check_table(table, feature_columns)
    labelled, _ = split_labelled(table)
    labelled, excluded, notes = _select_classes(labelled, min_per_class, purpose)
    X_all = _features(labelled, columns, "labelled rows")
    used, dropped, drop_notes = _drop_constant(X_all, columns)
    notes.extend(drop_notes)
    X = X_all[:, [columns.index(c) for c in used]]
    y = np.array([str(c) for c in labelled["fabric_class"]], dtype=object)
    return labelled, excluded, notes, used, dropped, X, y


#: Folds of the inner cross-validation that chooses among candidate feature sets.
INNER_FOLDS = 5


def inner_accuracy(table: pd.DataFrame, columns: list[str], reg: float | str = "auto", subspace: str = "none") -> float:
    """Accuracy of :func:`make_qda` by stratified k-fold (k = :data:`INNER_FOLDS` or the smallest class) over labelled rows."""
    labelled, _, notes, _, _, X, y = _labelled_data(table, columns, MIN_LOOCV_PER_CLASS, "choosing a feature set")
    folds = StratifiedKFold(n_splits=min(INNER_FOLDS, int(pd.Series(y).value_counts().min())), shuffle=True, random_state=0)
    correct = 0
    for train, test in folds.split(X, y):
        model = _fit(reg, X[train], y[train], notes, subspace)
        correct += int((model.predict(X[test]) == y[test]).sum())
    return correct / len(y)


def _distinct_candidates(table: pd.DataFrame, candidates: dict[str, list[str]]) -> dict[str, list[str]]:
    """The candidates less any whose varying columns repeat an earlier one's (same score; ties go to the first).

    A group whose extra columns are constant over the labelled rows (the shade
    descriptor of fits without a colour texture) is then scored once, not twice.
    """
    union = list(dict.fromkeys(c for columns in candidates.values() for c in columns))
    try:
        labelled = split_labelled(table)[0]
        varying = set(_drop_constant(_features(labelled, union, "labelled rows"), union)[0])
    except (KeyError, ValueError):  # choose_columns reports such problems per candidate
        return candidates
    distinct: dict[str, list[str]] = {}
    seen: set[tuple[str, ...]] = set()
    for name, columns in candidates.items():
        key = tuple(c for c in columns if c in varying)
        if key not in seen:
            seen.add(key)
            distinct[name] = columns
    return distinct


def choose_columns(table: pd.DataFrame, candidates: dict[str, list[str]], reg: float | str = "auto",
                   subspace: str = "none") -> tuple[str, dict[str, float]]:
    """The candidate column set with the highest :func:`inner_accuracy` on ``table`` (ties: the first listed), and every score.

    A single candidate is returned as it is, unscored.

    Raises
    ------
    ValueError
        When there is no candidate, or none can be scored.
    """
    if len(candidates) <= 1:
        if not candidates:
            raise ValueError("no candidate feature set to choose from")
        return next(iter(candidates)), {}
    scores: dict[str, float] = {}
    problems = []
    for name, columns in _distinct_candidates(table, candidates).items():
        try:
            scores[name] = inner_accuracy(table, columns, reg, subspace)
        except ValueError as err:
            problems.append(f"{name}: {str(err).splitlines()[0]}")
    if not scores:
        raise ValueError(f"no candidate feature set could be scored ({'; '.join(problems)})")
    order = list(candidates)
    return max(scores, key=lambda name: (scores[name], -order.index(name))), scores


def loocv(table: pd.DataFrame, feature_columns: list[str], reg: float | str = "auto",
          select_from: dict[str, list[str]] | None = None, subspace: str = "none") -> LoocvResult:
    """Leave-one-out cross-validation of :func:`make_qda` over the labelled rows.

    Each labelled image is classified by a model fitted (scaler included) on
    all other labelled images. Query rows are ignored. A class with fewer than
    :data:`MIN_LOOCV_PER_CLASS` labelled images cannot be left out and still
    be fitted, so it is excluded (recorded in ``excluded`` and ``notes``).
    Feature columns constant over the labelled images are dropped (noted).

    Parameters
    ----------
    table
        The feature table.
    feature_columns
        Names of the numeric feature columns to use (ignored with ``select_from``).
    reg
        Shrinkage: ``"auto"`` or a float in [0, 1].
    select_from
        Candidate column sets by name: each fold then uses the set that
        :func:`choose_columns` picks by an inner cross-validation of its
        *training* images only, so the held-out image never takes part in
        the choice (``selected`` counts the picks).
    subspace
        Feature space of the QDA (:func:`make_qda`).

    Returns
    -------
    LoocvResult

    Raises
    ------
    ValueError
        Missing or non-numeric columns, non-finite labelled features, or fewer
        than two classes with enough images.
    """
    reg, subspace = _check_reg(reg), _check_subspace(subspace)
    if select_from and len(select_from) == 1:  # nothing to choose: an ordinary LOOCV of that set
        feature_columns, select_from = next(iter(select_from.values())), None
    if select_from:
        feature_columns = list(dict.fromkeys(c for columns in select_from.values() for c in columns))
    labelled, excluded, notes, used, dropped, X, y = _labelled_data(table, feature_columns, MIN_LOOCV_PER_CLASS,
                                                                     "leave-one-out cross-validation")
    ids = labelled["image_id"].astype(str).tolist()
    classes = sorted(set(y))
    n = len(y)

    proba = np.zeros((n, len(classes)))
    selected: dict[str, int] = {}
    for i in range(n):
        train = np.arange(n) != i
        if select_from:
            rows = labelled.iloc[np.flatnonzero(train)]
            name, _ = choose_columns(rows, select_from, reg, subspace)
            selected[name] = selected.get(name, 0) + 1
            model = train_model(rows, select_from[name], reg, subspace)
            if model.classes != classes:
                raise ValueError(f"fold {ids[i]}: fitted classes {model.classes} differ from {classes}")
            proba[i] = predict(model, labelled.iloc[[i]])[[posterior_column(c) for c in classes]].to_numpy(float)[0]
            continue
        model = _fit(reg, X[train], y[train], notes, subspace)
        if list(model.classes_) != classes:
            raise ValueError(f"fold {ids[i]}: fitted classes {list(model.classes_)} differ from {classes}")
        proba[i] = _posteriors(model, X[i : i + 1], [ids[i]])[0]
    predicted = np.array([classes[k] for k in proba.argmax(axis=1)], dtype=object)

    predictions = pd.DataFrame({"image_id": ids, "true_class": y, "predicted_class": predicted})
    for k, c in enumerate(classes):
        predictions[posterior_column(c)] = proba[:, k]

    correct = int((predicted == y).sum())
    low, high = wilson_interval(correct, n)
    counts = pd.Series(y).value_counts()
    majority_class = sorted(c for c in classes if counts[c] == counts.max())[0]
    confusion = confusion_matrix(y, predicted, classes)
    per_class, class_notes = per_class_metrics(confusion)
    notes.extend(class_notes)
    return LoocvResult(
        classes=classes,
        feature_columns=used,
        dropped_columns=dropped,
        reg=reg,
        subspace=subspace,
        predictions=predictions,
        correct=correct,
        n=n,
        accuracy=correct / n,
        wilson_low=low,
        wilson_high=high,
        chance_uniform=1.0 / len(classes),
        chance_majority=float(counts.max()) / n,
        majority_class=majority_class,
        confusion=confusion,
        per_class=per_class,
        excluded=excluded,
        notes=notes,
        selected=selected,
    )


def confusion_matrix(true: Any, predicted: Any, classes: list[str]) -> pd.DataFrame:
    """Counts with rows = true class (index ``true_class``), columns = predicted class."""
    index = {c: k for k, c in enumerate(classes)}
    counts = np.zeros((len(classes), len(classes)), dtype=int)
    for t, p in zip(true, predicted):
        counts[index[t], index[p]] += 1
    return pd.DataFrame(
        counts,
        index=pd.Index(classes, name="true_class"),
        columns=pd.Index(classes, name="predicted_class"),
    )


def per_class_metrics(confusion: pd.DataFrame) -> tuple[pd.DataFrame, list[str]]:
    """Precision, recall and support per class from a confusion matrix.

    Precision of a class nothing was predicted as is 0 (with a note); recall
    of a class with no support is 0 (with a note).
    """
    counts = confusion.to_numpy()
    rows, notes = [], []
    for k, c in enumerate(confusion.index):
        tp, support, predicted = int(counts[k, k]), int(counts[k].sum()), int(counts[:, k].sum())
        if predicted == 0:
            notes.append(f"precision of {c!r} set to 0: no image was predicted as {c!r}")
        if support == 0:
            notes.append(f"recall of {c!r} set to 0: no image of {c!r} was scored")
        rows.append(
            {
                "class": c,
                "support": support,
                "predicted": predicted,
                "correct": tp,
                "precision": tp / predicted if predicted else 0.0,
                "recall": tp / support if support else 0.0,
            }
        )
    return pd.DataFrame(rows, columns=["class", "support", "predicted", "correct", "precision", "recall"]), notes


# --------------------------------------------------------------------------- final model


def train_model(table: pd.DataFrame, feature_columns: list[str], reg: float | str = "auto", subspace: str = "none") -> QdaModel:
    """Fit :func:`make_qda` on every labelled row (queries are ignored).

    Classes with fewer than :data:`MIN_TRAIN_PER_CLASS` labelled images are
    left out of the model (noted); feature columns constant over the labelled
    images are dropped (noted).

    Returns
    -------
    QdaModel
    """
    reg, subspace = _check_reg(reg), _check_subspace(subspace)
    labelled, excluded, notes, used, dropped, X, y = _labelled_data(table, feature_columns, MIN_TRAIN_PER_CLASS,
                                                                     "training QDA")
    pipeline = _fit(reg, X, y, notes, subspace)
    counts = pd.Series(y).value_counts()
    return QdaModel(
        parameters=QdaParameters.from_pipeline(pipeline),
        classes=[str(c) for c in pipeline.classes_],
        feature_columns=used,
        dropped_columns=dropped,
        reg=reg,
        subspace=subspace,
        var_floor=VAR_FLOOR,
        class_counts={str(c): int(counts[c]) for c in pipeline.classes_},
        excluded=excluded,
        notes=notes,
    )


def predict(model: QdaModel, table_rows: pd.DataFrame) -> pd.DataFrame:
    """Classify rows (typically the unlabelled queries) with a trained model.

    Parameters
    ----------
    model
        From :func:`train_model` or :func:`clothscope.qda_model.load_model`.
    table_rows
        Rows with ``image_id`` and the model's feature columns.

    Returns
    -------
    pandas.DataFrame
        ``image_id``, ``predicted_class`` and one ``p_<class>`` per model class
        (posteriors; each row sums to 1).
    """
    missing = [c for c in ["image_id", *model.feature_columns] if c not in table_rows.columns]
    if missing:
        raise ValueError(f"rows to classify lack column(s) {', '.join(map(repr, missing))}")
    out_columns = ["image_id", "predicted_class", *map(posterior_column, model.classes)]
    if len(table_rows) == 0:
        return pd.DataFrame(columns=out_columns)
    ids = table_rows["image_id"].astype(str).tolist()
    X = _features(table_rows, model.feature_columns, "rows to classify")
    with np.errstate(all="ignore"):
        proba = np.exp(model.parameters.log_posteriors(X))
    _check_posteriors(proba, ids)
    result = pd.DataFrame({"image_id": ids, "predicted_class": [model.classes[k] for k in proba.argmax(axis=1)]})
    for k, c in enumerate(model.classes):
        result[posterior_column(c)] = proba[:, k]
    return result[out_columns]


# --------------------------------------------------------------------------- reports


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
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    counts = confusion.to_numpy()
    k = len(confusion)
    side = max(4.0, 0.75 * k + 2.5)
    fig = Figure(figsize=(side + 1.0, side))
    FigureCanvasAgg(fig)
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
    fig.savefig(target, format="png", dpi=120)


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
    paths = {name: out / name for name in ("accuracy.json", "confusion.csv", "confusion.png", "per_class.csv", "predictions.csv")}
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
    write_json(paths["accuracy.json"], accuracy)
    _write_csv(paths["confusion.csv"], result.confusion, index=True)
    write_with(paths["confusion.png"], lambda tmp: _confusion_figure(result.confusion, title, tmp))
    _write_csv(paths["per_class.csv"], result.per_class)
    _write_csv(paths["predictions.csv"], predictions)
    return paths
