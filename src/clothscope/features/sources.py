"""Where a feature row's maps come from: the ground truth, a fit's output folder (relief or lit shading), or the prepared photo (luminance or shading)."""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from clothscope.core.imageio import luminance as photo_luminance
from clothscope.core.imageio import read_exr, read_png
from clothscope.core.truth import decode_normal, truth_paths
from clothscope.fit.outputs import HEIGHT_FILE, NORMAL_FILE, SHADE_FILE, STATE_FILE
from clothscope.fit.target import SHARE_FLOOR
from clothscope.prepare.image import IMAGE_FILE, STATUS_FILE, in_prepared_frame
from clothscope.prepare.shading import shading

#: Where the maps come from: synthetic ground truth, the inverse renderer, or the photo alone.
NORMAL_SOURCES = ("truth", "fitted", "photo")


#: What the structure descriptor reads on fitted maps (``features.fitted_field``): the height map, or the normal map lit by the fitted light.
FITTED_FIELDS = ("relief", "shading")
#: What the structure descriptor reads on the photo (``features.photo_field``): its luminance, or its shading with the dye colours divided out.
PHOTO_FIELDS = ("luminance", "shading")


#: Where the structure descriptor of the photo and fitted maps takes its thread period from (``features.period_source``):
#: each map's own lattice peaks, the period ``prepare`` measured on the photo at native resolution, or (``auto``) that
#: period only where the photo is larger than the working image, so that prepare saw more pixels than the map holds.
PERIOD_SOURCES = ("field", "prepare", "auto")


#: Status of a usable row.
STATUS_OK = "ok"


def finite_number(value: Any, name: str) -> float:
    """``value`` as a float; a ValueError naming ``name`` when it is NaN or infinite."""
    number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{name} is not finite: {value!r}")
    return number


@dataclass
class NormalInput:
    """An image's maps and BSDF parameters from one source, or why there are none.

    ``normals`` is what Algorithm 2 reads (normals or a grey-level map),
    ``field`` what the structure descriptor reads (a relief, a shading or a luminance).
    """

    normals: np.ndarray | None
    field: np.ndarray | None
    roughness: float
    specular: float
    status: str
    reason: str
    mitsuba_variant: str
    texels_per_pixel: float
    shade: np.ndarray | None = None  # fitted shade texture, when the fit has one
    unexplained: float = 0.0  # the log share of the photo the fit left unexplained (fitted rows only)


def unusable_input(status: str, reason: str, variant: str) -> NormalInput:
    return NormalInput(None, None, 0.0, 0.0, status, " ".join(reason.split()), variant, 0.0)


def truth_in_prepared_frame(normals: np.ndarray, height: np.ndarray,
                            prepared_dir: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray]:
    """The true normal and height maps cropped and resized as ``prepare`` made the working photo
    (:func:`clothscope.prepare.image.in_prepared_frame`), so they cover what the photo and fitted maps cover.

    Left as they are when the photo was rejected or its status is unreadable: there is no working frame then.
    """
    try:
        status = json.loads((Path(prepared_dir) / STATUS_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return normals, height
    if status.get("status") != "accepted":
        return normals, height
    framed = in_prepared_frame(normals, status)
    if framed is not normals:
        framed = framed / np.maximum(np.linalg.norm(framed, axis=-1, keepdims=True), 1e-12)
    return framed, in_prepared_frame(height, status)


def load_truth(image_path: str | os.PathLike[str], prepared_dir: str | os.PathLike[str] | None = None) -> NormalInput:
    """Ground-truth normal map and BSDF of a synthetic image; ``missing`` when the files are not there.

    With ``prepared_dir`` (the photo's prepared folder) the maps are put in the working photo's frame
    (:func:`truth_in_prepared_frame`); without it they keep the native photo's.
    """
    paths = truth_paths(Path(image_path))
    absent = [str(paths[k]) for k in ("normal", "height", "json") if not paths[k].is_file()]
    if absent:
        return unusable_input("missing", f"no ground truth for {image_path}: {', '.join(absent)} not found", "truth")
    try:
        truth = json.loads(paths["json"].read_text(encoding="utf-8"))
        normals = decode_normal(read_png(paths["normal"]))
        if normals.ndim != 3 or normals.shape[-1] < 3:
            raise ValueError(f"{paths['normal']}: expected an RGB normal map, got shape {normals.shape}")
        height = read_png(paths["height"]).astype(np.float64)
        height = height[..., 0] if height.ndim == 3 else height
        normals = normals[..., :3]
        if prepared_dir is not None:
            normals, height = truth_in_prepared_frame(normals, height, prepared_dir)
        return NormalInput(normals, height, finite_number(truth["roughness"], "roughness"), finite_number(truth["specular"], "specular"),
                           STATUS_OK, "", "truth", 1.0)
    except (OSError, ValueError, KeyError, TypeError) as err:
        return unusable_input("failed", f"ground truth of {image_path} unreadable: {type(err).__name__}: {err}", "truth")


def _read_record(path: Path, variant: str) -> dict[str, Any] | NormalInput:
    """A stage's JSON record, or a ``failed`` input saying why it cannot be read."""
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        return unusable_input("failed", f"{path} unreadable: {type(err).__name__}: {err}", variant)


def _read_three_channels(path: Path) -> np.ndarray:
    """The first three channels of an EXR written by this package, as float32 (H, W, 3)."""
    data = read_exr(path)
    if data.ndim != 3 or data.shape[-1] < 3:
        raise ValueError(f"{path.name}: expected 3 channels, got shape {data.shape}")
    return data[..., :3]


def lit_normals(normals: np.ndarray, light_position: Any) -> np.ndarray:
    """Lambert shading ``max(n . l, 0)`` of (H, W, 3) tangent-space normals under a distant light toward ``light_position``.

    Raises
    ------
    ValueError
        When the light position is not three finite numbers away from the origin.
    """
    position = np.asarray(light_position, dtype=np.float64)
    if position.shape != (3,) or not np.all(np.isfinite(position)) or np.linalg.norm(position) <= 0:
        raise ValueError(f"light position must be three finite numbers, not all zero; got {light_position!r}")
    return np.clip(np.asarray(normals, dtype=np.float64) @ (position / np.linalg.norm(position)), 0.0, None)


def log_unexplained(state: dict[str, Any]) -> float:
    """The natural log of a fit state's ``unexplained_share``, floored at :data:`~clothscope.fit.target.SHARE_FLOOR`.

    Raises
    ------
    ValueError
        When the state has no share (a fit of a version before it was recorded) or it is not finite.
    """
    if "unexplained_share" not in state:
        raise ValueError("state.json has no unexplained_share (a fit of an older clothscope version); "
                         "refit with --forcerun fit_normals")
    return math.log(max(finite_number(state["unexplained_share"], "unexplained_share"), SHARE_FLOOR))


def load_fitted(normals_dir: str | os.PathLike[str], field: str) -> NormalInput:
    """The fit_normals output of one image: ``state.json``, ``normal.exr``, ``height.exr`` and any ``shade.exr``.

    ``field`` (:data:`FITTED_FIELDS`) is what the structure descriptor will read:
    ``relief``, the height map, or ``shading``, the normal map lit by the
    fitted light (:func:`lit_normals`; the light of ``state.json``).
    """
    if field not in FITTED_FIELDS:
        raise ValueError(f"fitted field must be one of {', '.join(FITTED_FIELDS)}, got {field!r}")
    folder = Path(normals_dir)
    state = _read_record(folder / STATE_FILE, "")
    if isinstance(state, NormalInput):
        return state
    variant = str((state.get("runtime") or {}).get("mitsuba_variant", ""))
    status = state.get("status")
    if status != "fitted":
        status = status if status in ("skipped", "failed") else "failed"
        return unusable_input(status, str(state.get("reason") or f"fit status {state.get('status')!r}"), variant)
    try:
        material = state["material"]
        normals = _read_three_channels(folder / NORMAL_FILE)
        height = read_exr(folder / HEIGHT_FILE)[..., 0].astype(np.float64)
        shade = read_exr(folder / SHADE_FILE)[..., 0].astype(np.float64) if (folder / SHADE_FILE).is_file() else None
        if not all(np.all(np.isfinite(a)) for a in (normals, height, 0.0 if shade is None else shade)):
            raise ValueError(f"normal.exr, height.exr or {SHADE_FILE} holds non-finite values")
        described = height if field == "relief" else lit_normals(normals, state["scene"]["light"]["position"])
        return NormalInput(normals, described, finite_number(material["roughness"], "roughness"), finite_number(material["specular"], "specular"),
                           STATUS_OK, "", variant, finite_number(state.get("texels_per_pixel", 1.0), "texels_per_pixel"), shade,
                           log_unexplained(state))
    except (OSError, RuntimeError, ValueError, KeyError, TypeError) as err:
        return unusable_input("failed", f"{folder}: {type(err).__name__}: {err}", variant)


def load_photo(prepared_dir: str | os.PathLike[str], field: str) -> NormalInput:
    """The prepared photo's maps for the ``photo`` source (no BSDF).

    Algorithm 2 reads the linear luminance (Rec. 709 weights); the structure and LBP descriptors read
    ``field``: the luminance, or the ``shading`` with the dye colours divided out
    (:func:`clothscope.prepare.shading.shading`).
    """
    if field not in PHOTO_FIELDS:
        raise ValueError(f"photo field must be one of {', '.join(PHOTO_FIELDS)}, got {field!r}")
    folder = Path(prepared_dir)
    status = _read_record(folder / STATUS_FILE, "photo")
    if isinstance(status, NormalInput):
        return status
    if status.get("status") != "accepted":
        return unusable_input("skipped", f"photo rejected: {status.get('reason') or status.get('status')}", "photo")
    try:
        rgb = _read_three_channels(folder / IMAGE_FILE).astype(np.float64)
        if not np.all(np.isfinite(rgb)):
            raise ValueError("image.exr holds non-finite values")
        luminance = photo_luminance(rgb)
        described = shading(rgb) if field == "shading" else luminance
        return NormalInput(luminance, described, 0.0, 0.0, STATUS_OK, "", "photo", 1.0)
    except (OSError, RuntimeError, ValueError) as err:
        return unusable_input("failed", f"{folder}: {type(err).__name__}: {err}", "photo")


def prepared_period(prepared_dir: str | os.PathLike[str], larger_photos_only: bool = False) -> float | None:
    """The thread period (working pixels) ``prepare`` measured on the photo (``scale.working_period_px`` of its
    status record); None when it found no lattice, scaled the whole frame, or the record is unreadable.

    With ``larger_photos_only``, also None unless the photo's shorter side (``source_size``) exceeds the working
    resolution (``settings.working_resolution``): only then did prepare read the period from more pixels than the map.
    """
    try:
        status = json.loads((Path(prepared_dir) / STATUS_FILE).read_text(encoding="utf-8"))
        period = float((status.get("scale") or {}).get("working_period_px"))
        if larger_photos_only and min(status["source_size"]) <= status["settings"]["working_resolution"]:
            return None
    except (OSError, ValueError, TypeError, AttributeError, KeyError):
        return None
    return period if math.isfinite(period) and period > 0 else None


def descriptor_period(source: str, prepared_dir: str | os.PathLike[str] | None, texels_per_pixel: float,
                      period_source: str) -> float | None:
    """Thread period, in the pixels of ``source``'s map, that its structure descriptor takes; None: the map's own.

    With ``period_source`` ``prepare``, the photo and fitted maps take :func:`prepared_period` times
    ``texels_per_pixel`` (the map's pixels per working pixel); with ``auto`` the same, only for photos larger than
    the working image; the true relief always reads its own.
    """
    if period_source not in PERIOD_SOURCES:
        raise ValueError(f"period source must be one of {', '.join(PERIOD_SOURCES)}, got {period_source!r}")
    if period_source == "field" or source == "truth" or prepared_dir is None:
        return None
    period = prepared_period(prepared_dir, larger_photos_only=period_source == "auto")
    return None if period is None else period * texels_per_pixel


def load_normal_input(source: str, image_path: str | os.PathLike[str], source_dir: str | os.PathLike[str] | None,
                      fitted_field: str | None, photo_field: str | None) -> NormalInput:
    """:func:`load_truth` (``source_dir``: the prepared folder, or None to keep the native frame),
    :func:`load_fitted` (``source_dir``: fit_normals folder; ``fitted_field``: what its descriptor reads) or
    :func:`load_photo` (``source_dir``: prepared folder; ``photo_field``: what its descriptor reads), by ``source``."""
    if source == "truth":
        return load_truth(image_path, source_dir)
    if source in ("fitted", "photo"):
        if source_dir is None:
            raise ValueError(f"the {source} source needs its input folder")
        if source == "fitted":
            return load_fitted(source_dir, fitted_field)
        if photo_field is None:
            raise ValueError("the photo source needs its photo field (features.photo_field)")
        return load_photo(source_dir, photo_field)
    raise ValueError(f"normal source must be one of {', '.join(NORMAL_SOURCES)}, got {source!r}")
