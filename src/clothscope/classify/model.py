"""The trained classifier as data: arrays in ``model.npz`` and a JSON record in ``model.json``.

A model file never runs code when loaded: the arrays are read with
``numpy.load(allow_pickle=False)`` and the record is plain JSON. The record
names the format, the classes, the feature columns, the settings and the
SHA-256 of the arrays file, so a record and arrays from different runs, or a
file that is not a model, are refused with one line.

A saved model is a :class:`VotingModel`: one or more QDAs (:class:`QdaModel`),
each on its own column set, whose posteriors are averaged (one QDA: its own).
The arrays hold everything each QDA's posterior needs (:class:`QdaParameters`):
standardisation, the optional discriminant projection, and each class's
mean, covariance eigenvectors and eigenvalues and prior.
"""
from __future__ import annotations

import hashlib
import io
import json
import os
import zipfile
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy.special import logsumexp

from clothscope import __version__
from clothscope.classify.qda import VAR_FLOOR, check_posteriors, check_reg, check_subspace, fit_qda
from clothscope.classify.rows import (
    MIN_TRAIN_PER_CLASS,
    feature_matrix,
    labelled_data,
    posterior_column,
    with_own_tiles,
    with_tiles,
)
from clothscope.core.atomic import write_json, write_with

#: Marker of the record of a saved model; a record with another is refused.
MODEL_FORMAT = "clothscope-qda-model/3"
#: File names of a saved model inside its folder.
ARRAYS_NAME = "model.npz"
RECORD_NAME = "model.json"


@dataclass(frozen=True)
class QdaParameters:
    """What a fitted QDA pipeline computes posteriors from, as arrays.

    ``d`` features, ``k`` dimensions after projection (``k == d`` without one),
    ``C`` classes. Posteriors follow scikit-learn's QDA (eigen solver): the
    features are standardised (``mean``, ``scale``), projected (``projection``,
    ``d x k``), and class ``c`` scores ``log prior - (log det + Mahalanobis²) / 2``
    with covariance ``rotations[c] @ diag(scalings[c]) @ rotations[c].T``.
    """

    mean: np.ndarray         # (d,)
    scale: np.ndarray        # (d,)
    projection: np.ndarray   # (d, k)
    class_means: np.ndarray  # (C, k)
    rotations: np.ndarray    # (C, k, k)
    scalings: np.ndarray     # (C, k)
    log_priors: np.ndarray   # (C,)

    def __post_init__(self) -> None:
        d, k = self.projection.shape if self.projection.ndim == 2 else (-1, -1)
        n_classes = self.log_priors.shape[0] if self.log_priors.ndim == 1 else -1
        expected = {"mean": (d,), "scale": (d,), "projection": (d, k), "class_means": (n_classes, k),
                    "rotations": (n_classes, k, k), "scalings": (n_classes, k), "log_priors": (n_classes,)}
        for name, shape in expected.items():
            array = getattr(self, name)
            if not isinstance(array, np.ndarray) or array.dtype.kind != "f" or array.shape != shape or min(shape) < 1:
                raise ValueError(f"array {name!r} has shape {getattr(array, 'shape', None)}, expected {shape} of floats")
            if not np.isfinite(array).all():
                raise ValueError(f"array {name!r} holds non-finite values")
        if not ((self.scale > 0).all() and (self.scalings > 0).all()):
            raise ValueError("scales and class variances must be > 0")

    @property
    def n_features(self) -> int:
        """Number of input feature columns."""
        return int(self.mean.shape[0])

    @classmethod
    def from_pipeline(cls, pipeline: Any) -> QdaParameters:
        """Read the arrays of a fitted :func:`clothscope.classify.qda.make_qda` pipeline."""
        scaler, qda = pipeline.named_steps["scale"], pipeline.named_steps["qda"]
        project = pipeline.named_steps.get("project")
        d = scaler.mean_.shape[0]
        # LDA's transform with the eigen solver: X @ scalings_, first min(C - 1, d) columns
        projection = np.eye(d) if project is None else project.scalings_[:, : min(len(project.classes_) - 1, d)]
        return cls(
            mean=np.asarray(scaler.mean_, float), scale=np.asarray(scaler.scale_, float),
            projection=np.asarray(projection, float), class_means=np.asarray(qda.means_, float),
            rotations=np.stack(qda.rotations_).astype(float), scalings=np.stack(qda.scalings_).astype(float),
            log_priors=np.log(np.asarray(qda.priors_, float)),
        )

    def log_posteriors(self, X: np.ndarray) -> np.ndarray:
        """Log class posteriors of the rows of ``X`` (``n x d``); each row's exponentials sum to 1."""
        Z = ((np.asarray(X, float) - self.mean) / self.scale) @ self.projection
        scores = np.empty((Z.shape[0], self.log_priors.shape[0]))
        for c in range(self.log_priors.shape[0]):
            whitened = (Z - self.class_means[c]) @ (self.rotations[c] / np.sqrt(self.scalings[c]))
            scores[:, c] = self.log_priors[c] - 0.5 * (np.sum(whitened**2, axis=1) + np.sum(np.log(self.scalings[c])))
        return scores - logsumexp(scores, axis=1, keepdims=True)


@dataclass
class QdaModel:
    """A QDA trained on every labelled row, with what it was trained on."""

    parameters: QdaParameters
    classes: list[str]
    feature_columns: list[str]
    dropped_columns: list[str]
    reg: str | float
    subspace: str
    var_floor: float
    class_counts: dict[str, int]
    excluded: dict[str, list[str]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        if len(self.classes) != self.parameters.log_priors.shape[0]:
            raise ValueError(f"{len(self.classes)} class names for {self.parameters.log_priors.shape[0]} classes of arrays")
        if len(self.feature_columns) != self.parameters.n_features:
            raise ValueError(f"{len(self.feature_columns)} feature columns for arrays of {self.parameters.n_features} features")


@dataclass
class VotingModel:
    """QDAs on several column sets (``members``, by set name) that classify a row by the mean of their posteriors.

    One member is a plain QDA. ``metadata`` is the record it was loaded from (empty when trained here).
    """

    members: dict[str, QdaModel]
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.members:
            raise ValueError("a voting model needs at least one QDA")
        classes = {tuple(member.classes) for member in self.members.values()}
        if len(classes) != 1:
            raise ValueError(f"the QDAs of a voting model have different classes: {sorted(classes)}")

    @property
    def classes(self) -> list[str]:
        """The classes every member scores."""
        return list(next(iter(self.members.values())).classes)

    @property
    def feature_columns(self) -> list[str]:
        """Every column some member reads, in first-use order."""
        return list(dict.fromkeys(c for member in self.members.values() for c in member.feature_columns))


def _member_record(name: str, model: QdaModel) -> dict[str, Any]:
    return {
        "name": name,
        "feature_columns": list(model.feature_columns),
        "dropped_columns": list(model.dropped_columns),
        "class_counts": dict(model.class_counts),
        "excluded_classes": {c: list(ids) for c, ids in model.excluded.items()},
        "notes": list(model.notes),
    }


def _record(model: VotingModel, arrays_sha256: str, metadata: dict[str, Any]) -> dict[str, Any]:
    first = next(iter(model.members.values()))
    return {
        "format": MODEL_FORMAT,
        "status": "trained",
        "classes": model.classes,
        "feature_columns": model.feature_columns,
        "reg": first.reg,
        "subspace": first.subspace,
        "var_floor": float(first.var_floor),
        "members": [_member_record(name, member) for name, member in model.members.items()],
        "arrays": ARRAYS_NAME,
        "arrays_sha256": arrays_sha256,
        "clothscope_version": __version__,
        "metadata": dict(metadata),
    }


def _array_key(member: int, name: str) -> str:
    return f"m{member}_{name}"


def _arrays_bytes(model: VotingModel) -> bytes:
    buffer = io.BytesIO()
    np.savez(buffer, **{_array_key(k, f.name): getattr(member.parameters, f.name)
                        for k, member in enumerate(model.members.values()) for f in fields(QdaParameters)})
    return buffer.getvalue()


def as_voting(model: QdaModel | VotingModel, name: str = "model") -> VotingModel:
    """``model`` as a :class:`VotingModel` (a single QDA becomes its one member, called ``name``)."""
    return model if isinstance(model, VotingModel) else VotingModel({name: model})


def save_model(model: QdaModel | VotingModel, folder: str | os.PathLike[str], metadata: dict[str, Any] | None = None) -> None:
    """Write ``model`` to ``folder/model.npz`` (arrays) and ``folder/model.json`` (record), each atomically.

    ``metadata`` (the caller's, JSON-ready) is stored under ``"metadata"`` in the record.
    """
    model = as_voting(model)
    data = _arrays_bytes(model)
    folder = Path(folder)
    write_with(folder / ARRAYS_NAME, lambda tmp: tmp.write_bytes(data))
    write_json(folder / RECORD_NAME, _record(model, hashlib.sha256(data).hexdigest(), metadata or {}))


def save_untrained(folder: str | os.PathLike[str], reason: str, metadata: dict[str, Any] | None = None) -> None:
    """Write the files of :func:`save_model` for a model that could not be trained, saying why."""
    folder = Path(folder)
    write_with(folder / ARRAYS_NAME, lambda tmp: tmp.write_bytes(b""))
    write_json(folder / RECORD_NAME, {"format": MODEL_FORMAT, "status": "not trained", "reason": reason,
                                      "metadata": dict(metadata or {})})


def _read_record(path: Path) -> dict[str, Any]:
    try:
        record = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ValueError(f"{path}: model record does not exist (train a model with the workflow's classify rule)") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ValueError(f"{path}: not a readable model record ({type(err).__name__})") from None
    found = record.get("format") if isinstance(record, dict) else None
    if isinstance(found, str) and found.startswith(MODEL_FORMAT.rsplit("/", 1)[0] + "/") and found != MODEL_FORMAT:
        raise ValueError(f"{path}: model record of format {found}, this clothscope reads {MODEL_FORMAT}; "
                         "retrain it with the workflow's classify rule")
    if found != MODEL_FORMAT:
        raise ValueError(f"{path}: not a clothscope model record (expected format {MODEL_FORMAT})")
    if record.get("status") != "trained":
        raise ValueError(f"{path}: model was not trained: {record.get('reason', 'no reason recorded')}")
    return record


def _read_arrays(path: Path, sha256: Any, members: int) -> list[QdaParameters]:
    try:
        data = path.read_bytes()
    except OSError:
        raise ValueError(f"{path}: model arrays file cannot be read") from None
    if hashlib.sha256(data).hexdigest() != sha256:
        raise ValueError(f"{path}: arrays do not match the record beside them (SHA-256 differs)")
    names = [f.name for f in fields(QdaParameters)]
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as archive:
            missing = sorted({_array_key(k, n) for k in range(members) for n in names} - set(archive.files))
            if missing:
                raise ValueError(f"{path}: model arrays lack {', '.join(missing)}")
            return [QdaParameters(**{name: archive[_array_key(k, name)] for name in names}) for k in range(members)]
    except (OSError, zipfile.BadZipFile) as err:
        raise ValueError(f"{path}: not a model arrays file ({type(err).__name__})") from None
    except ValueError as err:
        message = str(err)
        raise ValueError(message if message.startswith(str(path)) else f"{path}: {message}") from None


def _member(entry: dict[str, Any], parameters: QdaParameters, record: dict[str, Any]) -> QdaModel:
    return QdaModel(
        parameters=parameters, classes=[str(c) for c in record["classes"]],
        feature_columns=[str(c) for c in entry["feature_columns"]],
        dropped_columns=[str(c) for c in entry.get("dropped_columns", [])], reg=record["reg"],
        subspace=str(record["subspace"]), var_floor=float(record["var_floor"]),
        class_counts={str(k): int(v) for k, v in entry["class_counts"].items()},
        excluded={str(k): list(v) for k, v in entry.get("excluded_classes", {}).items()},
        notes=list(entry.get("notes", [])),
    )


def load_model(folder: str | os.PathLike[str]) -> VotingModel:
    """Load a model written by :func:`save_model` from its folder, validating record and arrays.

    Raises
    ------
    ValueError
        One line naming the file and the problem: missing, not a model, not
        trained, arrays that do not match the record or are malformed.
    """
    folder = Path(folder)
    record = _read_record(folder / RECORD_NAME)
    members = record.get("members")
    if not isinstance(members, list) or not members or not all(isinstance(m, dict) for m in members):
        raise ValueError(f"{folder / RECORD_NAME}: model record lists no QDA (members)")
    parameters = _read_arrays(folder / ARRAYS_NAME, record.get("arrays_sha256"), len(members))
    try:
        return VotingModel({str(entry["name"]): _member(entry, arrays, record) for entry, arrays in zip(members, parameters)},
                           metadata=record)
    except (KeyError, TypeError, AttributeError) as err:
        raise ValueError(f"{folder / RECORD_NAME}: model record lacks or garbles {err}") from None
    except ValueError as err:
        raise ValueError(f"{folder / RECORD_NAME}: {err}") from None


def train_model(table: pd.DataFrame, feature_columns: list[str], reg: float | str = "auto", subspace: str = "none",
                tiles: pd.DataFrame | None = None) -> QdaModel:
    """Fit :func:`make_qda` on every labelled row (queries are ignored) and the ``tiles`` of those images.

    Classes with fewer than :data:`MIN_TRAIN_PER_CLASS` labelled images are
    left out of the model (noted); feature columns constant over the labelled
    images are dropped (noted).

    Returns
    -------
    QdaModel
    """
    reg, subspace = check_reg(reg), check_subspace(subspace)
    labelled, excluded, notes, used, dropped, X, y = labelled_data(table, feature_columns, MIN_TRAIN_PER_CLASS,
                                                                     "training QDA")
    pipeline = fit_qda(reg, *with_tiles(X, y, labelled["image_id"].astype(str).to_numpy(), tiles, used), notes, subspace)
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


def _posteriors(model: QdaModel, X: np.ndarray) -> np.ndarray:
    with np.errstate(all="ignore"):
        return np.exp(model.parameters.log_posteriors(X))


def _row_posteriors(model: QdaModel, X: np.ndarray, ids: list[str], tiles: pd.DataFrame | None) -> np.ndarray:
    """(rows, classes) posteriors of one QDA; with ``tiles``, each row's mean over itself and its image's tiles."""
    proba = _posteriors(model, X)
    for k, image_id in enumerate(ids) if tiles is not None else ():
        looks = with_own_tiles(X[k : k + 1], image_id, tiles, model.feature_columns)[1:]
        if len(looks):
            proba[k] = (proba[k] + _posteriors(model, looks).sum(axis=0)) / (1 + len(looks))
    return proba


def predict(model: QdaModel | VotingModel, table_rows: pd.DataFrame, tiles: pd.DataFrame | None = None) -> pd.DataFrame:
    """Classify rows (typically the unlabelled queries) with a trained model.

    Parameters
    ----------
    model
        From :func:`train_model` or :func:`clothscope.classify.model.load_model`; a
        :class:`VotingModel` scores each row by the mean of its members' posteriors.
    table_rows
        Rows with ``image_id`` and the model's feature columns.
    tiles
        Tile rows (:func:`clothscope.classify.feature_sets.joined_tiles`): each row is then classified by the
        mean posterior of the row and its image's tiles (``classify.test_tiles: mean``); None: by the row alone.

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
    members = list(as_voting(model).members.values())
    proba = sum(_row_posteriors(member, feature_matrix(table_rows, member.feature_columns, "rows to classify"), ids, tiles)
                for member in members) / len(members)
    check_posteriors(proba, ids)
    result = pd.DataFrame({"image_id": ids, "predicted_class": [model.classes[k] for k in proba.argmax(axis=1)]})
    for k, c in enumerate(model.classes):
        result[posterior_column(c)] = proba[:, k]
    return result[out_columns]
