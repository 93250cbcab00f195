"""Stage 0, ``prepare``: decode a photo into the working image every fit starts from.

Decodes, applies EXIF orientation, converts sRGB to linear, centre-crops to a
square, resizes to the working resolution and marks clipped pixels. A bad
image is not an error of the run: :func:`prepare_image` records a rejection
with a one-line reason instead.

Scale from the threads (``prepare.scale: threads``): the thread period is
measured on the photo at its native resolution (:func:`native_period`), by
default on its shading with the yarn colours divided out. When
downscaling the whole frame would put it below ``period_band[0]`` working
pixels, only a centred square is kept, sized so that the period lands at the
band's geometric centre; threads finer than the band even at native resolution
are magnified, up to ``max_upsample`` times (1: never). The status record says
what was found and chosen (``scale``), so a thread count per original pixel is known.
"""
from __future__ import annotations

import json
import os
import traceback
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image
from scipy import ndimage

from clothscope.core.atomic import atomic_dir, write_json
from clothscope.core.imageio import (
    ImageRejected,
    decode_image,
    header_size,
    linear_to_srgb,
    luminance,
    write_exr,
    write_png,
)
from clothscope.features.structure import (
    Lattice,
    Spectrum,
    StructureSettings,
    analysis_field,
    find_lattice,
    folded_angle,
    refined_radius,
    spectrum,
)
from clothscope.prepare.shading import shading

STATUS_FILE = "status.json"
IMAGE_FILE = "image.exr"
CLIPPED_FILE = "clipped.png"
PREVIEW_FILE = "preview.png"
#: which lattice peak gives the native period (``prepare.period_peak``): the most powerful, the one with the most
#: power times frequency (a colour repeat many threads long then loses to the threads it is woven from), or that
#: one among the peaks along the yarn axes when the photo shows them (a weave repeat then loses too), or that, with a
#: (1, 1) harmonic stepped down to the threads when the photo shows no yarn axes (round, ring-lit crossings), or that,
#: with a higher harmonic of the threads stepped down to them there too (a sharp rib or float edge under a ring light)
PERIOD_PEAKS = ("weighted", "strongest", "axes", "axes_harmonic", "axes_fundamental")
#: the yarn axes count when the 4-fold moment of the gradient orientations is at least this (:func:`yarn_axes`)
AXES_MIN_STRENGTH = 0.1
#: a lattice peak lies along a yarn axis when its direction is within this many degrees of one
AXES_TOLERANCE_DEG = 12.0
#: the threads' peak below a (1, 1) harmonic lies within this fraction of 1/sqrt(2) of its radius ...
HARMONIC_RADIUS_TOLERANCE = 0.05
#: ... within this many degrees of 45 degrees from its direction ...
HARMONIC_ANGLE_TOLERANCE_DEG = 8.0
#: ... and holds at least this fraction of its power (:func:`threads_below_harmonic`)
HARMONIC_MIN_POWER = 0.3
#: a pick is stepped down to the threads' peak at 1/m of its radius for these m (:func:`fundamental_below`)
FUNDAMENTAL_ORDERS = (2, 3, 4)


@dataclass(frozen=True)
class PrepareSettings:
    """Knobs of the prepare stage (``prepare:`` in the config schema, which holds the defaults)."""

    working_resolution: int
    min_input_px: int
    max_megapixels: float
    clip_threshold: float
    max_clipped_fraction: float
    scale: str  # "threads": crop so the thread period lands in period_band (needs a lattice test)
    period_band: tuple[float, float]  # wanted thread period, working pixels
    max_upsample: float  # the most a thread crop may be magnified (1: never smaller than the working image)
    period_window: int  # side of the native-resolution centre square the period is measured on
    period_field: str  # what the period is measured on: "shading" (yarn colours divided out) or "luminance"
    period_peak: str  # which lattice peak gives the period, one of PERIOD_PEAKS
    min_detail: float  # least thread-scale detail (grey levels of 255, thread_detail) of an accepted image

    def __post_init__(self) -> None:  # the schema checks every range; it cannot say low < high
        low, high = self.period_band
        if not low < high:
            raise ValueError(f"period_band must be [low, high] with low < high, got {list(self.period_band)}")
        object.__setattr__(self, "period_band", (float(low), float(high)))
        check_period_peak(self.period_peak)


#: Peak memory of one prepare process, from ``workflow/benchmarks/large_photo.py`` (12-100 MP): at most this
#: many MB with Python and its imports, plus so many MB per decoded megapixel by file type (8- and 16-bit codes
#: decode through tables; a 16-bit PNG also passes through Mitsuba's bitmap, so any PNG is counted at its rate).
PREPARE_BASE_MB = 250
PREPARE_MB_PER_MEGAPIXEL = {".exr": 27.0, ".png": 23.0}
PREPARE_MB_PER_MEGAPIXEL_8BIT = 20.0
#: The request is the expected peak times this, plus what a cluster job's own Snakemake processes hold.
MEMORY_HEADROOM = 1.5
SNAKEMAKE_JOB_MB = 300


def prepare_memory_mb(path: str | os.PathLike[str], max_megapixels: float = float("inf")) -> int:
    """The ``prepare`` job's memory request (MB) for the photo at ``path``, from its header's pixel count.

    A photo above ``max_megapixels`` is rejected from its header, so it is counted at that
    limit; an unreadable one (the job only records why) at zero megapixels.
    """
    size = header_size(path)
    megapixels = min(size[0] * size[1] / 1e6, max_megapixels) if size else 0.0
    per_megapixel = PREPARE_MB_PER_MEGAPIXEL.get(Path(path).suffix.lower(), PREPARE_MB_PER_MEGAPIXEL_8BIT)
    return int(np.ceil(MEMORY_HEADROOM * (PREPARE_BASE_MB + per_megapixel * megapixels) + SNAKEMAKE_JOB_MB))


def check_period_peak(peak: str) -> None:
    """Raise ``ValueError`` unless ``peak`` names a rule of :data:`PERIOD_PEAKS`."""
    if peak not in PERIOD_PEAKS:
        raise ValueError(f"period_peak must be one of {', '.join(PERIOD_PEAKS)}, got {peak!r}")


def native_period(rgb: np.ndarray, window: int, lattice: StructureSettings, field: str = "shading",
                  peak: str = "weighted") -> float | None:
    """Thread period (native pixels) of the photo's centred ``window`` square, or None when no lattice stands out.

    The peaks are those of :func:`clothscope.features.structure.find_lattice` (the
    descriptor's peak test) at native resolution, on the luminance or on the shading
    with the yarn colours divided out (:func:`clothscope.prepare.shading.shading`);
    the period is that of the peak :func:`period_peak_radius` picks (``peak``).
    """
    check_period_peak(peak)
    return lattice_period(native_lattice(rgb, window, lattice, field), peak)


def lattice_period(native: NativeLattice, peak: str) -> float | None:
    """Thread period (native pixels) that the pick ``peak`` reads from a :class:`NativeLattice`; None without a lattice."""
    if not native.found.found:
        return None
    radius = period_peak_radius(native.spectrum, native.found.peaks, peak, native.axes)
    return float(native.side / radius) if radius > 0 else None


@dataclass(frozen=True)
class YarnAxes:
    """The two yarn directions of a field, as one angle modulo 90 degrees, and how clearly the field shows them."""

    angle: float  # radians, the direction of one axis (the other is 90 degrees on)
    strength: float  # in [0, 1]: 0 for gradients of every direction alike, 1 for gradients along the axes only


@dataclass(frozen=True)
class NativeLattice:
    """What :func:`native_period` reads of a photo: the square's side (pixels), its spectrum, lattice peaks and yarn axes."""

    side: int
    spectrum: Spectrum
    found: Lattice
    axes: YarnAxes


def yarn_axes(field: np.ndarray) -> YarnAxes:
    """The yarn axes of an analysis field: the 4-fold moment of its gradient orientations.

    Gradients (after a 1 px Gaussian) are weighted by their squared length. Where
    the yarns' edges carry most of that weight, the moment's phase over 4 is a yarn
    direction and its modulus says how clearly the field shows it (round, ring-lit
    crossings or a smooth rib much stronger than the edges leave it low or turn it).
    """
    gy, gx = np.gradient(ndimage.gaussian_filter(np.asarray(field, dtype=np.float64), 1.0))
    weight = gx**2 + gy**2
    total = float(weight.sum())
    if not total > 0:
        return YarnAxes(0.0, 0.0)
    moment = complex((weight * np.exp(4j * np.arctan2(gy, gx))).sum()) / total
    return YarnAxes(float(np.angle(moment) / 4), float(abs(moment)))


def native_lattice(rgb: np.ndarray, window: int, lattice: StructureSettings, field: str = "shading") -> NativeLattice:
    """The photo's centred ``window`` square as :func:`native_period` reads it (:class:`NativeLattice`)."""
    square = centred(rgb, window)[..., :3]
    values = analysis_field(shading(square) if field == "shading" else luminance(square), 0.0)
    s = spectrum(values)
    return NativeLattice(square.shape[0], s, find_lattice(s, lattice), yarn_axes(values))


def period_peak_radius(s: Spectrum, peaks: np.ndarray, peak: str, axes: YarnAxes | None = None) -> float:
    """Radius (bins) of the lattice peak that gives the thread period (:func:`period_peak_index`)."""
    return refined_radius(s, int(peaks[period_peak_index(s, peaks, peak, axes)]))


def along_axes(s: Spectrum, peaks: np.ndarray, axes: YarnAxes) -> np.ndarray:
    """Mask of the ``peaks`` whose direction lies within :data:`AXES_TOLERANCE_DEG` of a yarn axis."""
    direction = np.arctan2(s.dy.flat[peaks], s.dx.flat[peaks])
    off = np.abs((direction - axes.angle + np.pi / 4) % (np.pi / 2) - np.pi / 4)
    return off <= np.deg2rad(AXES_TOLERANCE_DEG)


def period_peak_index(s: Spectrum, peaks: np.ndarray, peak: str, axes: YarnAxes | None = None) -> int:
    """Index into ``peaks`` of the lattice peak that gives the thread period.

    ``strongest``: the most powerful peak. ``weighted``: the peak with the most
    power times radius. A colour repeat many threads long (a stripe or check of
    one hue in two shades, which the shading cannot divide out) can outshine the
    threads, but it sits at a fraction of their frequency; a harmonic of the
    threads sits at a multiple and would need over half their power to win.
    ``axes``: as ``weighted``, among the peaks along the yarn ``axes``
    (:func:`along_axes`) when their strength is at least :data:`AXES_MIN_STRENGTH`
    and some peak lies along them; a weave repeat (a plain weave's checkerboard,
    a twill's ribs, a satin's floats) lies off them. ``axes_harmonic``: as
    ``axes``; when the axes do not restrict the pick, a (1, 1) harmonic is
    stepped down to the threads (:func:`threads_below_harmonic`): round, ring-lit
    crossings show no yarn axes, and their (1, 1) harmonic can win.
    ``axes_fundamental``: as ``axes_harmonic``, and then a 2nd to 4th harmonic
    of the threads is stepped down to them (:func:`fundamental_below`), when the
    axes do not restrict the pick either.

    Raises
    ------
    ValueError
        For an unknown ``peak``, an empty ``peaks``, or ``axes`` without yarn axes.
    """
    check_period_peak(peak)
    if len(peaks) == 0:
        raise ValueError("no lattice peaks to choose the period from")
    peaks = np.asarray(peaks)
    radii, power = radii_and_power(s, peaks)
    score = power if peak == "strongest" else power * radii
    if peak in ("axes", "axes_harmonic", "axes_fundamental"):
        if axes is None:
            raise ValueError(f"period_peak {peak!r} needs the yarn axes of the field")
        aligned = along_axes(s, peaks, axes)
        if axes.strength >= AXES_MIN_STRENGTH and aligned.any():
            return int(np.argmax(np.where(aligned, score, -np.inf)))
        if peak in ("axes_harmonic", "axes_fundamental"):
            pick = threads_below_harmonic(s, peaks, int(np.argmax(score)))
            return fundamental_below(s, peaks, pick) if peak == "axes_fundamental" else pick
    return int(np.argmax(score))


def fundamental_below(s: Spectrum, peaks: np.ndarray, pick: int) -> int:
    """Index into ``peaks`` of the threads' peak when ``pick`` is their m-th harmonic, else ``pick``.

    A thread lattice has no peak at 1/m (m in :data:`FUNDAMENTAL_ORDERS`) of its
    peak's radius in the same direction: weave repeats (a plain weave's
    checkerboard, a twill's or satin's floats) lie off the thread directions. A
    peak there (within :data:`HARMONIC_RADIUS_TOLERANCE` of the radius and
    :data:`HARMONIC_ANGLE_TOLERANCE_DEG` of the direction) that holds at least
    the pick's power is the threads', and ``pick`` its harmonic. Of several,
    the most powerful is taken.
    """
    peaks = np.asarray(peaks)
    radii, power = radii_and_power(s, peaks)
    turn = undirected_turn(s, peaks, pick)
    near = np.zeros(len(peaks), dtype=bool)
    for m in FUNDAMENTAL_ORDERS:
        near |= np.abs(radii / (radii[pick] / m) - 1) < HARMONIC_RADIUS_TOLERANCE
    near &= (turn < np.deg2rad(HARMONIC_ANGLE_TOLERANCE_DEG)) & (power >= power[pick])
    near[pick] = False
    return int(np.flatnonzero(near)[np.argmax(power[near])]) if near.any() else pick


def radii_and_power(s: Spectrum, peaks: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Refined radius (bins) and smoothed power of each of ``peaks``."""
    return np.array([refined_radius(s, int(k)) for k in peaks]), s.smoothed.flat[peaks]


def undirected_turn(s: Spectrum, peaks: np.ndarray, pick: int) -> np.ndarray:
    """Angle (radians, in [0, pi/2]) between each peak's direction and the pick's, up to sign."""
    direction = np.arctan2(s.dy.flat[peaks], s.dx.flat[peaks])
    return folded_angle(direction - direction[pick])


def threads_below_harmonic(s: Spectrum, peaks: np.ndarray, pick: int, min_power: float = HARMONIC_MIN_POWER) -> int:
    """Index into ``peaks`` of the threads' peak when ``pick`` is their (1, 1) harmonic, else ``pick``.

    The threads' peaks of a square lattice lie at 1/sqrt(2) of its (1, 1)
    harmonic's radius, 45 degrees from it. The strongest peak there (within
    :data:`HARMONIC_RADIUS_TOLERANCE` and :data:`HARMONIC_ANGLE_TOLERANCE_DEG`)
    is taken when it holds at least ``min_power`` of the pick's power. A plain
    weave's checkerboard of floats puts peaks at the same place below the
    threads, which only the power ratio tells apart.
    """
    peaks = np.asarray(peaks)
    radii, power = radii_and_power(s, peaks)
    turn = undirected_turn(s, peaks, pick)
    near = ((np.abs(radii / (radii[pick] / np.sqrt(2)) - 1) < HARMONIC_RADIUS_TOLERANCE)
            & (np.abs(turn - np.pi / 4) < np.deg2rad(HARMONIC_ANGLE_TOLERANCE_DEG)))
    if near.any() and power[near].max() >= min_power * power[pick]:
        return int(np.flatnonzero(near)[np.argmax(power[near])])
    return pick


def thread_crop(source_side: int, period: float | None, settings: PrepareSettings) -> tuple[int, dict[str, Any]]:
    """Side of the centred square to keep, and the ``scale`` record of the status.

    The whole frame is kept unless its downscaled thread period would fall
    below ``period_band[0]``; then the crop puts it at the band's geometric
    centre, but never smaller than ``working_resolution / max_upsample`` (with
    ``max_upsample`` 1, no upsampling).
    """
    size = settings.working_resolution
    low, high = settings.period_band
    record: dict[str, Any] = {"method": settings.scale, "native_period_px": period, "period_band": [low, high]}
    crop = source_side
    if period is None:
        record["note"] = "no thread lattice found at native resolution: the whole frame is used"
    else:
        if period * size / source_side < low:
            smallest = min(int(np.ceil(size / settings.max_upsample)), source_side)
            crop = int(np.clip(round(size * period / np.sqrt(low * high)), smallest, source_side))
        working = period * size / crop
        if working < low:
            magnified = f" magnified {size / crop:.2g} times" if crop < size else " at full native resolution"
            record["note"] = (f"threads are {working:.1f} px at the working resolution, below {low:g} px, even{magnified}: "
                              "photograph closer")
        elif working > high:
            record["note"] = f"threads are {working:.1f} px at the working resolution, above {high:g} px: few threads in view"
        record["working_period_px"] = working
    record.update(crop_px=int(crop), native_px_per_working_px=crop / size)
    return crop, record


def working_crop(rgb: np.ndarray, settings: PrepareSettings, lattice: StructureSettings | None) -> tuple[int, dict[str, Any]]:
    """Side of the centred square ``prepare`` resizes, and the status's ``scale`` record (``settings.scale``)."""
    side = min(rgb.shape[:2])
    if settings.scale == "frame":
        return side, {"method": "frame", "crop_px": side, "native_px_per_working_px": side / settings.working_resolution}
    period = native_period(rgb, settings.period_window, lattice, settings.period_field, settings.period_peak)
    return thread_crop(side, period, settings)


def centre_square(array: np.ndarray) -> np.ndarray:
    """Crop the largest centred square from an (H, W, ...) array."""
    height, width = array.shape[:2]
    side = min(height, width)
    top, left = (height - side) // 2, (width - side) // 2
    return array[top : top + side, left : left + side]


def resize_channel(channel: np.ndarray, size: int, upsample: Image.Resampling = Image.Resampling.BICUBIC) -> np.ndarray:
    """Area-average (down) or ``upsample`` (default bicubic) resize of one float channel to size x size."""
    method = Image.Resampling.BOX if channel.shape[0] >= size else upsample
    resized = Image.fromarray(np.ascontiguousarray(channel, dtype=np.float32), mode="F").resize((size, size), method)
    return np.asarray(resized, dtype=np.float32)


def centred(array: np.ndarray, side: int | None) -> np.ndarray:
    """The centred ``side`` x ``side`` square of an (H, W, ...) array (None: the largest)."""
    square = centre_square(array)
    if side is None or side >= square.shape[0]:
        return square
    top = (square.shape[0] - side) // 2
    return square[top : top + side, top : top + side]


def resized_square(array: np.ndarray, size: int, crop: int | None = None,
                   upsample: Image.Resampling = Image.Resampling.BICUBIC) -> np.ndarray:
    """The centred ``crop`` square (default the largest) of an (H, W) or (H, W, C) array, each channel resized to ``size``
    (``upsample``: the filter when that magnifies)."""
    square = centred(array, crop)
    if square.ndim == 2:
        return resize_channel(square, size, upsample)
    return np.stack([resize_channel(square[..., c], size, upsample) for c in range(square.shape[-1])], axis=-1)


def to_working_resolution(rgb: np.ndarray, clipped: np.ndarray, size: int, crop: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Centre-crop (to ``crop`` px, default the largest square) and resize linear RGB and the clipped mask to ``size``.

    A working pixel is clipped when any source pixel under it was clipped. The mask is resized by area in both
    directions: a bicubic magnification would spread each clipped pixel onto its unclipped neighbours.
    """
    out = resized_square(rgb[..., :3], size, crop)
    mask = resized_square(clipped.astype(np.float32), size, crop, upsample=Image.Resampling.BOX) > 1e-6
    return np.clip(out, 0.0, None), mask


def in_prepared_frame(array: np.ndarray, status: dict[str, Any]) -> np.ndarray:
    """A map of the photo's native frame (same size as the photo) cropped and resized as ``prepare`` made the working image.

    ``status`` is the photo's accepted status record (``source_size``, ``scale.crop_px``,
    ``settings.working_resolution``). A map that the crop and resize leave as it is comes back unchanged.

    Raises
    ------
    ValueError
        When the map's size is not the photo's.
    """
    source = [int(v) for v in status["source_size"]]
    if list(array.shape[1::-1]) != source:
        raise ValueError(f"a {array.shape[1]}x{array.shape[0]} px map does not match its {source[0]}x{source[1]} px photo")
    size = int(status["settings"]["working_resolution"])
    crop = int((status.get("scale") or {}).get("crop_px", min(source)))
    if crop == size == min(source) and source[0] == source[1]:
        return array
    return resized_square(np.asarray(array, dtype=np.float32), size, crop)


#: Standard deviation (working pixels) of the Gaussian whose residual is the thread-scale detail of :func:`thread_detail`.
DETAIL_SIGMA_PX = 4.0


def thread_detail(rgb: np.ndarray) -> float:
    """RMS of the working image's sRGB luminance less its Gaussian blur of :data:`DETAIL_SIGMA_PX`, in grey levels of 255.

    Measured inside a tenth of the side from each edge. Detail finer than a few
    pixels is what the fit and the descriptors read; a black, uniform or smoothly
    shaded frame (nothing in focus, or no cloth) has almost none.
    """
    grey = linear_to_srgb(rgb) @ np.array([0.2126, 0.7152, 0.0722], dtype=np.float32)
    detail = grey.astype(np.float64) - ndimage.gaussian_filter(grey.astype(np.float64), DETAIL_SIGMA_PX, mode="reflect")
    edge = int(0.1 * min(detail.shape))
    inner = detail[edge : detail.shape[0] - edge, edge : detail.shape[1] - edge]
    return float(np.sqrt(np.mean(inner**2)) * 255.0)


def check_detail(path: str | os.PathLike[str], rgb: np.ndarray, min_detail: float) -> float:
    """The image's :func:`thread_detail`; raises :class:`ImageRejected` when it is below ``min_detail``."""
    detail = thread_detail(rgb)
    if detail < min_detail:
        raise ImageRejected(f"{path}: no thread-scale texture (detail {detail:.2f} of 255 grey levels, limit {min_detail:g}, "
                            "prepare.min_detail): out of focus, too dark or uniform")
    return detail


def prepare_image(image_id: str, path: str | os.PathLike[str], out_dir: str | os.PathLike[str], settings: PrepareSettings,
                  lattice: StructureSettings | None = None) -> dict[str, Any]:
    """Prepare one image into ``out_dir`` (written atomically) and return its status record.

    The record's ``status`` is ``"accepted"`` or ``"rejected"``; a rejected image
    has a one-line ``reason`` and no pixel outputs. ``lattice`` is the peak
    test of the thread period, needed by ``settings.scale == "threads"``.
    """
    if settings.scale == "threads" and lattice is None:
        raise ValueError("prepare.scale 'threads' needs the lattice peak test (features.structure)")
    record: dict[str, Any] = {"image_id": image_id, "path": str(path), "settings": asdict(settings)}
    with atomic_dir(out_dir) as tmp:
        try:
            decoded = decode_image(path, settings.min_input_px, settings.max_megapixels, settings.clip_threshold)
            crop, scale = working_crop(decoded.rgb, settings, lattice)
            rgb, clipped = to_working_resolution(decoded.rgb, decoded.clipped, settings.working_resolution, crop)
            fraction = float(clipped.mean())
            if fraction > settings.max_clipped_fraction:
                raise ImageRejected(
                    f"{path}: {fraction:.0%} of the image is clipped (limit {settings.max_clipped_fraction:.0%}); "
                    "expose it darker"
                )
            detail = check_detail(path, rgb, settings.min_detail)
            write_exr(tmp / IMAGE_FILE, rgb)
            write_png(tmp / CLIPPED_FILE, clipped.astype(np.float32))
            write_png(tmp / PREVIEW_FILE, linear_to_srgb(rgb))
            record.update(
                status="accepted",
                reason="",
                source_format=decoded.source_format,
                bit_depth=decoded.bit_depth,
                source_size=[int(decoded.rgb.shape[1]), int(decoded.rgb.shape[0])],
                clipped_fraction=fraction,
                thread_detail=detail,
                scale=scale,
                mean_linear_rgb=[float(v) for v in rgb.reshape(-1, 3).mean(axis=0)],
                notes=decoded.notes,
            )
        except ImageRejected as err:
            record.update(status="rejected", reason=str(err))
        except Exception as err:  # noqa: BLE001 - one bad image must not sink the run
            first_line = (str(err).splitlines() or [""])[0]
            record.update(
                status="rejected",
                reason=f"{path}: unexpected {type(err).__name__} while decoding: {first_line}",
                traceback=traceback.format_exc(),
            )
        write_json(tmp / STATUS_FILE, record)
    return record


def read_status(prepared_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """Read the status record of a prepared image folder."""
    return json.loads((Path(prepared_dir) / STATUS_FILE).read_text(encoding="utf-8"))
