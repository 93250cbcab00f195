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
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy.stats import binomtest
from sklearn.model_selection import RepeatedStratifiedKFold, StratifiedKFold

from clothscope.classify.model import QdaModel, VotingModel, as_voting, predict, train_model
from clothscope.classify.qda import check_reg, check_subspace, fit_qda, posteriors
from clothscope.classify.rows import (
    MIN_LOOCV_PER_CLASS,
    drop_constant,
    feature_matrix,
    labelled_data,
    posterior_column,
    split_labelled,
    with_own_tiles,
    with_tiles,
)


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

    def selected_counts(self) -> str:
        """The sets the folds chose (or that voted), most often first: ``name count, ...``."""
        return ", ".join(f"{name} {count}" for name, count in sorted(self.selected.items(), key=lambda kv: -kv[1]))

    def right_by_image(self) -> pd.Series:
        """Whether each image was classified correctly (boolean, by image id)."""
        predictions = self.predictions.set_index("image_id")
        return predictions["predicted_class"] == predictions["true_class"]


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


# --------------------------------------------------------------------------- LOOCV


#: Folds of the inner cross-validation that chooses among candidate feature sets.
INNER_FOLDS = 5


def inner_folds(table: pd.DataFrame, columns: list[str], reg: float | str, subspace: str, tiles: pd.DataFrame | None,
                repeats: int = 1) -> Iterator[tuple[Any, np.ndarray, np.ndarray]]:
    """``(model, X_test, y_test)`` of each fold of a stratified k-fold (k = :data:`INNER_FOLDS` or the smallest class)
    over the labelled rows, ``repeats`` times with other splits.

    Each fold's :func:`make_qda` also trains on the ``tiles`` of its training images (:func:`with_tiles`); the
    test rows are whole images.
    """
    labelled, _, notes, used, _, X, y = labelled_data(table, columns, MIN_LOOCV_PER_CLASS, "choosing a feature set")
    ids = labelled["image_id"].astype(str).to_numpy()
    k = min(INNER_FOLDS, int(pd.Series(y).value_counts().min()))
    folds = (StratifiedKFold(n_splits=k, shuffle=True, random_state=0) if repeats == 1
             else RepeatedStratifiedKFold(n_splits=k, n_repeats=repeats, random_state=0))
    for train, test in folds.split(X, y):
        yield fit_qda(reg, *with_tiles(X[train], y[train], ids[train], tiles, used), notes, subspace), X[test], y[test]


def inner_hits(table: pd.DataFrame, columns: list[str], reg: float | str, subspace: str,
               tiles: pd.DataFrame | None) -> np.ndarray:
    """1 for each image of :func:`inner_folds` (one split, in fold order) its fold's model classifies right, else 0.

    The split depends on the labels only, so two column sets' hits pair image by image.
    """
    return np.concatenate([(model.predict(X) == y).astype(int)
                           for model, X, y in inner_folds(table, columns, reg, subspace, tiles)])


def sign_test_p(wins: int, losses: int) -> float:
    """One-sided sign test: the chance of at least ``wins`` heads in ``wins + losses`` fair coin flips (1 for none)."""
    if wins < 0 or losses < 0:
        raise ValueError(f"sign_test_p needs counts >= 0, got wins={wins}, losses={losses}")
    return float(binomtest(wins, wins + losses, 0.5, alternative="greater").pvalue) if wins + losses else 1.0


@dataclass(frozen=True)
class Choice:
    """How :func:`choose_columns` picks among candidate column sets.

    Without ``prefer`` (None), the set with the best inner accuracy. With it,
    the ``prefer`` set unless the best one classifies more of the inner
    images that the two disagree on, by a one-sided sign test at ``alpha``
    (:func:`sign_test_p`); a ``prefer`` that is not among the candidates
    leaves the best one. Built from the config by :meth:`from_config`.
    """

    prefer: str | None
    alpha: float

    def __post_init__(self) -> None:
        if not (isinstance(self.alpha, (int, float)) and 0 < self.alpha < 1):
            raise ValueError(f"choice alpha must be a number in (0, 1), got {self.alpha!r}")

    @classmethod
    def from_config(cls, section: dict[str, Any]) -> Choice:
        """From the config's ``classify.choice`` (``prefer: none`` is no preferred set)."""
        return cls(None if section["prefer"] == "none" else str(section["prefer"]), float(section["alpha"]))


def evident_gain(won: np.ndarray, held: np.ndarray, alpha: float) -> bool:
    """Whether the hits ``won`` beat the paired hits ``held`` (:func:`inner_hits`) by a sign test at ``alpha``."""
    return sign_test_p(int((won > held).sum()), int((won < held).sum())) < alpha


def _distinct_candidates(table: pd.DataFrame, candidates: dict[str, list[str]]) -> dict[str, list[str]]:
    """The candidates less any whose varying columns repeat an earlier one's (same score; ties go to the first).

    A group whose extra columns are constant over the labelled rows (the shade
    descriptor of fits without a colour texture) is then scored once, not twice.
    """
    union = list(dict.fromkeys(c for columns in candidates.values() for c in columns))
    try:
        labelled = split_labelled(table)[0]
        varying = set(drop_constant(feature_matrix(labelled, union, "labelled rows"), union)[0])
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


def _best_scored(scores: dict[str, Any], order: list[str]) -> str:
    """The name with the highest score; ties go to the one first in ``order``."""
    return max(scores, key=lambda name: (scores[name], -order.index(name)))


#: An inner score of one column set: called as ``score(table, columns, reg, subspace, tiles)``; higher is better.
InnerScore = Callable[..., Any]


def choose_columns(table: pd.DataFrame, candidates: dict[str, list[str]], reg: float | str = "auto",
                   subspace: str = "none", tiles: pd.DataFrame | None = None,
                   score: InnerScore | None = None, choice: Choice | None = None) -> tuple[str, dict[str, Any]]:
    """The candidate column set with the highest ``score`` (None: the accuracy of :func:`inner_hits`) on ``table``
    (ties: the first listed), or ``choice.prefer`` where the best does not beat it plainly (:class:`Choice`; None:
    the best), and every score.

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
    hits: dict[str, np.ndarray] = {}  # each candidate's inner hits, computed once

    def hits_of(name: str) -> np.ndarray:
        if name not in hits:
            hits[name] = inner_hits(table, candidates[name], reg, subspace, tiles)
        return hits[name]

    scores: dict[str, Any] = {}
    problems = []
    for name, columns in _distinct_candidates(table, candidates).items():
        try:
            scores[name] = float(hits_of(name).mean()) if score is None else score(table, columns, reg, subspace, tiles)
        except ValueError as err:
            problems.append(f"{name}: {str(err).splitlines()[0]}")
    if not scores:
        raise ValueError(f"no candidate feature set could be scored ({'; '.join(problems)})")
    best = _best_scored(scores, list(candidates))
    if choice is not None and choice.prefer in scores and best != choice.prefer and not evident_gain(
            hits_of(best), hits_of(choice.prefer), choice.alpha):
        return choice.prefer, scores
    return best, scores


def class_posteriors(model: QdaModel | VotingModel, queries: pd.DataFrame, classes: list[str],
                     tiles: pd.DataFrame | None) -> np.ndarray:
    """(rows, classes) posteriors of ``queries`` under a trained model whose classes are ``classes`` (``tiles``:
    :func:`predict`)."""
    if model.classes != classes:
        raise ValueError(f"a fold's model has classes {model.classes}, not {classes}")
    return predict(model, queries, tiles)[[posterior_column(c) for c in classes]].to_numpy(float)


def plainly_beaten(rows: pd.DataFrame, candidates: dict[str, list[str]], reg: float | str, subspace: str,
                   tiles: pd.DataFrame | None, alpha: float) -> set[str]:
    """The candidates whose :func:`inner_hits` on ``rows`` the best-scoring candidate beats by the sign test of
    :func:`evident_gain` at ``alpha`` (ties for best: the first listed); those that cannot be scored count as beaten.

    Raises
    ------
    ValueError
        When ``alpha`` is not in (0, 1).
    """
    if not 0 < alpha < 1:
        raise ValueError(f"the pruning level must be in (0, 1), got {alpha!r}")
    hits, beaten = {}, set()
    for name, columns in candidates.items():
        try:
            hits[name] = inner_hits(rows, columns, reg, subspace, tiles)
        except ValueError:
            beaten.add(name)
    if hits:
        best = _best_scored({name: float(h.mean()) for name, h in hits.items()}, list(candidates))
        beaten |= {name for name in hits if evident_gain(hits[best], hits[name], alpha)}
    return beaten


def train_vote(rows: pd.DataFrame, candidates: dict[str, list[str]], reg: float | str, subspace: str,
               tiles: pd.DataFrame | None, prune: float = 0.0) -> VotingModel:
    """A QDA of each distinct candidate set (:func:`_distinct_candidates`), trained on ``rows`` and the ``tiles``
    of those images, as one :class:`VotingModel`.

    Every set votes with equal weight. With ``prune`` > 0, the sets that the best
    one beats plainly in an inner cross-validation of ``rows`` (:func:`plainly_beaten`
    at that level) do not vote; where none can be scored (too few images for the
    inner folds), all vote. At 0 nothing is scored. A set that cannot be trained
    (no column varies) does not vote.

    Raises
    ------
    ValueError
        When no candidate can be trained.
    """
    distinct = _distinct_candidates(rows, candidates)
    if prune:
        beaten = plainly_beaten(rows, distinct, reg, subspace, tiles, prune)
        distinct = {name: columns for name, columns in distinct.items() if name not in beaten} or distinct
    members, problems = {}, []
    for name, columns in distinct.items():
        try:
            members[name] = train_model(rows, columns, reg, subspace, tiles)
        except ValueError as err:
            problems.append(f"{name}: {str(err).splitlines()[0]}")
    if not members:
        raise ValueError(f"no candidate feature set could be trained ({'; '.join(problems)})")
    return VotingModel(members)


def candidates_model(rows: pd.DataFrame, candidates: dict[str, list[str]], reg: float | str, subspace: str,
                     tiles: pd.DataFrame | None, score: InnerScore | None = None, choice: Choice | None = None,
                     vote: bool = False, prune: float = 0.0) -> VotingModel:
    """The classifier of a candidate list trained on ``rows`` and their ``tiles``: with ``vote``, a QDA on every
    distinct candidate not pruned at ``prune`` (:func:`train_vote`); else the QDA of the one :func:`choose_columns`
    picks (by ``score`` and ``choice``; a single candidate: that one), as a one-member :class:`VotingModel` named
    after it."""
    if vote:
        return train_vote(rows, candidates, reg, subspace, tiles, prune)
    chosen = choose_columns(rows, candidates, reg, subspace, tiles, score, choice)[0]
    return as_voting(train_model(rows, candidates[chosen], reg, subspace, tiles), chosen)


def loocv(table: pd.DataFrame, feature_columns: list[str], reg: float | str = "auto",
          select_from: dict[str, list[str]] | None = None, subspace: str = "none",
          tiles: pd.DataFrame | None = None, score: InnerScore | None = None,
          choice: Choice | None = None, test_tiles: bool = False, vote: bool = False,
          prune: float = 0.0) -> LoocvResult:
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
        the choice (``selected`` counts the picks). With ``vote``, nothing is
        chosen: each fold averages the posteriors of every candidate's QDA
        (:func:`train_vote`; ``selected`` counts the votes), less those pruned at
        ``prune`` by an inner cross-validation of the fold's training images.
    subspace
        Feature space of the QDA (:func:`make_qda`).
    tiles
        Tile rows (:func:`clothscope.classify.feature_sets.joined_tiles`): each fold also trains on the
        tiles of its training images, never on those of the image it scores, which is scored by its own row.
    score, choice
        The inner score :func:`choose_columns` chooses by, and how (with ``select_from``).
    test_tiles
        Score the held-out image by the mean posterior of its whole row and its own tiles
        (``classify.test_tiles: mean``) instead of its whole row alone; the inner choice is unchanged.

    Returns
    -------
    LoocvResult

    Raises
    ------
    ValueError
        Missing or non-numeric columns, non-finite labelled features, or fewer
        than two classes with enough images.
    """
    reg, subspace = check_reg(reg), check_subspace(subspace)
    if select_from and len(select_from) == 1:  # nothing to choose: an ordinary LOOCV of that set
        feature_columns, select_from = next(iter(select_from.values())), None
    if select_from:
        feature_columns = list(dict.fromkeys(c for columns in select_from.values() for c in columns))
    labelled, excluded, notes, used, dropped, X, y = labelled_data(table, feature_columns, MIN_LOOCV_PER_CLASS,
                                                                     "leave-one-out cross-validation")
    ids = labelled["image_id"].astype(str).tolist()
    classes = sorted(set(y))
    n = len(y)

    proba = np.zeros((n, len(classes)))
    selected: dict[str, int] = {}
    for i in range(n):
        train = np.arange(n) != i
        if select_from:
            rows, query = labelled.iloc[np.flatnonzero(train)], labelled.iloc[[i]]
            fold_model = candidates_model(rows, select_from, reg, subspace, tiles, score, choice, vote, prune)
            proba[i] = class_posteriors(fold_model, query, classes, tiles if test_tiles else None)[0]
            for name in fold_model.members:
                selected[name] = selected.get(name, 0) + 1
            continue
        model = fit_qda(reg, *with_tiles(X[train], y[train], np.asarray(ids)[train], tiles, used), notes, subspace)
        if list(model.classes_) != classes:
            raise ValueError(f"fold {ids[i]}: fitted classes {list(model.classes_)} differ from {classes}")
        rows = with_own_tiles(X[i : i + 1], ids[i], tiles, used) if test_tiles else X[i : i + 1]
        proba[i] = posteriors(model, rows, [ids[i]] * len(rows)).mean(axis=0)
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


# --------------------------------------------------------------------------- reports


