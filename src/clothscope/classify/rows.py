"""Rows of a feature table: labelled and query images, checked feature matrices, classes big enough to use."""
from __future__ import annotations

import numpy as np
import pandas as pd

from clothscope.features.structure import TILE_FEATURES

#: A class needs this many labelled images to be fitted (QDA needs a covariance).
MIN_TRAIN_PER_CLASS = 2


#: ... and this many to be scored by LOOCV (every training fold still has 2).
MIN_LOOCV_PER_CLASS = 3


#: Prefix of the posterior columns in prediction tables.
POSTERIOR_PREFIX = "p_"


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


def check_table(table: pd.DataFrame, feature_columns: list[str]) -> list[str]:
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


def feature_matrix(rows: pd.DataFrame, columns: list[str], what: str) -> np.ndarray:
    """Float feature matrix of ``rows``; ValueError naming non-numeric columns or non-finite rows."""
    frame = rows[columns]
    try:
        numeric = all(pd.api.types.is_numeric_dtype(kind) for kind in frame.dtypes)
        X = (frame if numeric else frame.apply(pd.to_numeric, errors="raise")).to_numpy(dtype=float)
    except (ValueError, TypeError) as err:
        raise ValueError(f"{what}: feature columns must be numeric: {err}") from None
    bad = ~np.isfinite(X).all(axis=1)
    if bad.any():
        ids = rows["image_id"].astype(str).to_numpy()[bad]
        raise ValueError(f"{what}: non-finite feature value(s) in image(s) {', '.join(ids[:10])}{' ...' if len(ids) > 10 else ''}")
    return X


def drop_constant(X: np.ndarray, columns: list[str]) -> tuple[list[str], list[str], list[str]]:
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


def select_classes(labelled: pd.DataFrame, minimum: int, purpose: str) -> tuple[pd.DataFrame, dict[str, list[str]], list[str]]:
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


def posterior_column(fabric_class: str) -> str:
    """Name of the posterior column of a class: ``p_<class>``."""
    return f"{POSTERIOR_PREFIX}{fabric_class}"


def labelled_data(table: pd.DataFrame, feature_columns: list[str], min_per_class: int,
                   purpose: str) -> tuple[pd.DataFrame, dict, list[str], list[str], list[str], np.ndarray, np.ndarray]:
    """Labelled rows of classes with enough images, their usable (non-constant) features and labels.

    Returns labelled rows, excluded classes, notes, used and dropped columns, X and y.
    """
    columns = check_table(table, feature_columns)
    labelled, _ = split_labelled(table)
    labelled, excluded, notes = select_classes(labelled, min_per_class, purpose)
    X_all = feature_matrix(labelled, columns, "labelled rows")
    used, dropped, drop_notes = drop_constant(X_all, columns)
    notes.extend(drop_notes)
    X = X_all[:, [columns.index(c) for c in used]]
    y = np.array([str(c) for c in labelled["fabric_class"]], dtype=object)
    return labelled, excluded, notes, used, dropped, X, y


def tiles_describe(tiles: pd.DataFrame | None, columns: list[str]) -> bool:
    """Whether ``tiles`` has rows and ``columns`` hold a column a tile describes
    (:data:`~clothscope.features.structure.TILE_FEATURES`, plain or as ``<source>.<column>``)."""
    return tiles is not None and not tiles.empty and any(c.rsplit(".", 1)[-1] in TILE_FEATURES for c in columns)


def with_own_tiles(X: np.ndarray, image_id: str, tiles: pd.DataFrame | None, columns: list[str]) -> np.ndarray:
    """One image's row ``X`` (``1 x d``) with the rows of its own tiles below it (``classify.test_tiles``).

    Only when :func:`tiles_describe` and the image has tiles; otherwise ``X`` unchanged.
    """
    if not tiles_describe(tiles, columns):
        return X
    rows = tiles[tiles["image_id"].astype(str) == str(image_id)]
    return X if rows.empty else np.vstack([X, feature_matrix(rows, columns, f"tile rows of {image_id}")])


def with_tiles(X: np.ndarray, y: np.ndarray, ids: list[str] | np.ndarray, tiles: pd.DataFrame | None,
               columns: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """``X`` and ``y`` with the tile rows of the images ``ids`` appended, each labelled as its image.

    Tiles (``features.tiles``) are sub-windows of an image's map described on their own: extra
    training rows of that image. Only tiles of the images passed in are added, so a model trained on
    some images never sees a tile of another. ``tiles`` None or empty, or ``columns`` without any column a
    tile describes (:data:`~clothscope.features.structure.TILE_FEATURES`, plain or as ``<source>.<column>``):
    ``X`` and ``y`` unchanged, since copies of an image's own values would only make its class look tighter.
    """
    if not tiles_describe(tiles, columns):
        return X, y
    label = {str(i): c for i, c in zip(ids, y)}
    rows = tiles[tiles["image_id"].astype(str).isin(label)]
    if rows.empty:
        return X, y
    extra = feature_matrix(rows, columns, "tile rows")
    return np.vstack([X, extra]), np.concatenate([y, np.array([label[str(i)] for i in rows["image_id"]], dtype=object)])
