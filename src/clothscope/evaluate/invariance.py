"""Invariance checks of the spectrum features: rotate / zoom a normal map, count changed predictions.

The classifier's features are ``roughness``, ``specular`` and the Fourier peak
features of the normal map (:mod:`clothscope.features.paper`). A fabric seen at
another orientation or distance should keep its predicted class, so this
module provides

* :func:`rotate_map`: rotate a z map or a normal map in the image plane and
  crop the largest square that holds valid (interpolated, not padded) texels;
* :func:`zoom_map`: magnify a map about its centre (a closer camera) and crop
  it to the original size;
* :func:`prediction_change_rate`: leave-one-out predictions of each image from
  its original and its transformed features, and the share that differ.

Recolouring
-----------
None of the features takes the colour image: ``roughness`` and ``specular``
are material parameters and the spectrum features are computed from the
normal map alone (:func:`clothscope.features.paper.analyse_normal_map` accepts only
a normal / z map). On *ground-truth* normal maps recolouring is therefore an
identity on the feature vector, by construction, and there is nothing to
measure. Whether recolouring changes predictions in practice depends on
whether the *fitted* normal map, roughness and specular depend on the dye;
that has to be measured on maps fitted to recoloured renders, which this
module does not do.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib.colors import hsv_to_rgb, rgb_to_hsv
from scipy import ndimage

from clothscope.classify.qda import make_qda

#: Interpolation order used for resampling (cubic spline: keeps the thread
#: harmonics; linear interpolation low-pass filters them noticeably).
ORDER = 3
#: Texels dropped on each side of the rotated valid square (spline support).
ROTATE_MARGIN = 1


def _check_map(array: np.ndarray) -> np.ndarray:
    array = np.asarray(array, dtype=np.float64)
    if not (array.ndim == 2 or (array.ndim == 3 and array.shape[-1] == 3)):
        raise ValueError(f"map must have shape (H, W) or (H, W, 3), got {array.shape}")
    if array.shape[0] != array.shape[1]:
        raise ValueError(f"map must be square, got {array.shape[0]}x{array.shape[1]}")
    if not np.all(np.isfinite(array)):
        raise ValueError("map contains NaN or infinite values")
    return array


def _resample(array: np.ndarray, matrix: np.ndarray, out_size: int) -> np.ndarray:
    """Sample ``array`` (H, W[, C]) at ``centre_in + matrix @ (p - centre_out)`` for an out_size^2 grid."""
    size = array.shape[0]
    c_in = (size - 1) / 2.0
    c_out = (out_size - 1) / 2.0
    rows, cols = np.mgrid[0:out_size, 0:out_size].astype(np.float64)
    offsets = np.stack([rows.ravel() - c_out, cols.ravel() - c_out])
    coords = matrix @ offsets + c_in
    channels = [array] if array.ndim == 2 else [array[..., k] for k in range(array.shape[-1])]
    out = [
        ndimage.map_coordinates(ch, coords, order=ORDER, mode="mirror").reshape(out_size, out_size)
        for ch in channels
    ]
    return out[0] if array.ndim == 2 else np.stack(out, axis=-1)


def _renormalise(normals: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(normals, axis=-1, keepdims=True)
    return normals / np.maximum(length, 1e-12)


def rotated_crop_size(size: int, degrees: float) -> int:
    """Side of the centred axis-aligned square inside a ``size`` square rotated by ``degrees``."""
    theta = math.radians(degrees)
    side = size / (abs(math.cos(theta)) + abs(math.sin(theta)))
    return max(1, int(math.floor(side + 1e-9)) - 2 * ROTATE_MARGIN)


def rotate_map(map_: np.ndarray, degrees: float) -> np.ndarray:
    """Rotate a z map (H, W) or a normal map (H, W, 3) counter-clockwise and crop the valid centre.

    The content is rotated by ``degrees`` about the map centre (cubic-spline
    resampling); the output is the largest centred square lying inside the
    rotated original, less a :data:`ROTATE_MARGIN` texel margin (185 texels
    for a 256-texel map at 30 degrees), so no texel is padded. For a normal
    map the tangent-plane components (x, y) are rotated with the surface and
    the vectors renormalised; z is unchanged by an in-plane rotation.

    Raises
    ------
    ValueError
        On a wrong shape, a non-square map or non-finite values.
    """
    array = _check_map(map_)
    out_size = rotated_crop_size(array.shape[0], degrees)
    theta = math.radians(degrees)
    c, s = math.cos(theta), math.sin(theta)
    # Output (row, col) offset -> input offset: inverse rotation. Rows point down,
    # so a counter-clockwise rotation on screen is (x, y_up) -> R (x, y_up).
    inverse = np.array([[c, s], [-s, c]])
    out = _resample(array, inverse, out_size)
    if array.ndim == 3:
        x, y = out[..., 0].copy(), out[..., 1].copy()
        # Tangent-space x points right, y up (OpenGL convention): rotate the vectors CCW too.
        out[..., 0] = c * x - s * y
        out[..., 1] = s * x + c * y
        out = _renormalise(out)
    return out


def zoom_map(map_: np.ndarray, factor: float) -> np.ndarray:
    """Magnify a z map or normal map by ``factor >= 1`` about its centre, keeping its size.

    Models a camera ``factor`` times closer: every period becomes ``factor``
    times longer in texels and the centre ``1 / factor`` of the map fills the
    output. Normal vectors keep their direction (the surface is unchanged,
    only sampled more densely); they are renormalised after interpolation.

    Raises
    ------
    ValueError
        If ``factor`` is not a finite number >= 1 (zooming out would need
        texels the map does not have), or on a bad map.
    """
    if isinstance(factor, bool) or not isinstance(factor, (int, float, np.number)) or not math.isfinite(factor) or factor < 1:
        raise ValueError(f"zoom factor must be a finite number >= 1, got {factor!r}")
    array = _check_map(map_)
    out = _resample(array, np.eye(2) / float(factor), array.shape[0])
    return _renormalise(out) if array.ndim == 3 else out


def _check_photo(rgb: np.ndarray) -> np.ndarray:
    array = np.asarray(rgb, dtype=np.float64)
    if array.ndim != 3 or array.shape[-1] != 3 or array.shape[0] != array.shape[1]:
        raise ValueError(f"photo must be a square (N, N, 3) RGB array, got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError("photo contains NaN or infinite values")
    return array


def rotate_photo(rgb: np.ndarray, degrees: float) -> np.ndarray:
    """Rotate an RGB photo (values in [0, 1]) about its centre and crop the valid centre, as :func:`rotate_map`."""
    array = _check_photo(rgb)
    theta = math.radians(degrees)
    c, s = math.cos(theta), math.sin(theta)
    out = _resample(array, np.array([[c, s], [-s, c]]), rotated_crop_size(array.shape[0], degrees))
    return np.clip(out, 0.0, 1.0)


def zoom_photo(rgb: np.ndarray, factor: float) -> np.ndarray:
    """The centre ``1 / factor`` of an RGB photo (a camera ``factor`` times closer), at its own pixel size.

    No resampling: the prepare stage resizes every photo to the working
    resolution, so the threads come out ``factor`` times longer there.
    """
    if not math.isfinite(factor) or factor < 1:
        raise ValueError(f"zoom factor must be a finite number >= 1, got {factor!r}")
    array = _check_photo(rgb)
    side = max(1, int(round(array.shape[0] / factor)))
    start = (array.shape[0] - side) // 2
    return array[start : start + side, start : start + side].copy()


def shift_hue(rgb: np.ndarray, degrees: float) -> np.ndarray:
    """Turn every pixel's hue by ``degrees`` (HSV), keeping saturation and value: a cloth dyed another colour."""
    hsv = rgb_to_hsv(np.clip(_check_photo(rgb), 0.0, 1.0))
    hsv[..., 0] = (hsv[..., 0] + degrees / 360.0) % 1.0
    return hsv_to_rgb(hsv)


#: The photo transformations of the fitted-map invariance benchmark, by name.
PHOTO_TRANSFORMS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "rotate30": lambda rgb: rotate_photo(rgb, 30.0),
    "zoom1.5": lambda rgb: zoom_photo(rgb, 1.5),
    "hue120": lambda rgb: shift_hue(rgb, 120.0),
}


ModelFactory = Callable[[], Any]


@dataclass(frozen=True)
class ChangeReport:
    """Leave-one-out predictions of each image from original and transformed features.

    Attributes
    ----------
    predicted_original, predicted_transformed : numpy.ndarray
        Class predicted for each held-out image from its original / transformed
        features, by a model fitted on the *original* features of all other images.
    labels : numpy.ndarray
        True classes.
    changed : numpy.ndarray
        Boolean mask of the images whose prediction changed.
    """

    predicted_original: np.ndarray
    predicted_transformed: np.ndarray
    labels: np.ndarray
    changed: np.ndarray

    @property
    def change_rate(self) -> float:
        """Share of images whose predicted class changed."""
        return float(self.changed.mean()) if self.changed.size else 0.0

    @property
    def accuracy(self) -> float:
        """Leave-one-out accuracy on the original features."""
        return float((self.predicted_original == self.labels).mean()) if self.labels.size else 0.0

    @property
    def accuracy_transformed(self) -> float:
        """Leave-one-out accuracy on the transformed features (model trained on originals)."""
        return float((self.predicted_transformed == self.labels).mean()) if self.labels.size else 0.0


def prediction_change_rate(
    original: np.ndarray,
    transformed: np.ndarray,
    labels: np.ndarray | list[str],
    model_factory: ModelFactory | None = None,
) -> ChangeReport:
    """Leave-one-out: how often does transforming the held-out image change its predicted class?

    For each image ``i`` a fresh model (``model_factory()``, default
    :func:`clothscope.classify.qda.make_qda`) is fitted on the original features
    of all other images and predicts image ``i`` from its original and from
    its transformed features.

    Parameters
    ----------
    original, transformed : numpy.ndarray
        (n, d) feature matrices, same row order and columns.
    labels : array-like
        n class labels.
    model_factory : callable, optional
        Returns an unfitted scikit-learn-style classifier.

    Returns
    -------
    ChangeReport
    """
    X = np.asarray(original, dtype=np.float64)
    Xt = np.asarray(transformed, dtype=np.float64)
    y = np.asarray(labels, dtype=object)
    if X.ndim != 2 or X.shape != Xt.shape or len(y) != X.shape[0]:
        raise ValueError(f"feature matrices must be (n, d) of the same shape with n labels, got {X.shape}, {Xt.shape}, {len(y)}")
    if not (np.isfinite(X).all() and np.isfinite(Xt).all()):
        raise ValueError("feature matrices contain NaN or infinite values")
    factory = model_factory or make_qda
    n = X.shape[0]
    pred = np.empty(n, dtype=object)
    pred_t = np.empty(n, dtype=object)
    for i in range(n):
        train = np.arange(n) != i
        model = factory().fit(X[train], y[train])
        both = model.predict(np.vstack([X[i], Xt[i]]))
        pred[i], pred_t[i] = both[0], both[1]
    return ChangeReport(pred, pred_t, y, pred != pred_t)
