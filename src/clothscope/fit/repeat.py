"""The photo's repeat, and a prior that keeps the fitted relief repeating with it.

Woven cloth repeats: the pattern of crossings one weave repeat away is the
same. One photo under one light leaves much of the height map unconstrained,
and the fit fills it with detail that does not repeat (fibre and sensor noise,
a ramp across a float ended by a step, a frame at the border). Where the photo
itself repeats, the relief should repeat with it.

:func:`photo_repeats` finds the translations under which the photo's shading
(the dye layout divided out, :func:`clothscope.prepare.shading.shading`, and
shading wider than :data:`HIGHPASS_PX` removed) correlates best with itself:
the peaks of its normalised autocorrelation. The shortest strong peak is the
first translation, the shortest strong one in another direction the second. A
photo whose best peak correlates less than :data:`MIN_CORRELATION` (no
repeat: pile, melange, noise) gets none.

:func:`shifted_samples` turns a translation into the bilinear gathers of the
height map one translation away from each texel, and ``repeat_weight`` times
the mean squared difference between a texel and its translate (texel widths,
over the texels whose translate lies on the map, times the photo's own
correlation at that translation) is added to the normal-map stage's loss
(:mod:`.normals`). A relief that repeats with the photo costs nothing, whatever
its shape within the repeat.
"""
from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType
from typing import Any

import drjit as dr
import numpy as np
from scipy import ndimage

from clothscope.prepare.shading import shading

#: width (working pixels) of the Gaussian whose blur is taken out of the shading first: folds are the mesh's
HIGHPASS_PX = 16.0
#: a photo whose best autocorrelation peak is below this does not repeat
MIN_CORRELATION = 0.3
#: peaks of at least this fraction of the best correlation count as strong
STRONG_FRACTION = 0.8
#: shortest translation searched (working pixels): below it the autocorrelation is the blur's, not a repeat
MIN_SHIFT_PX = 3.0
#: longest translation searched, as a fraction of the photo's side (the overlap must stay large)
MAX_SHIFT_FRACTION = 0.35
#: a second translation must turn at least this far from the first
MIN_TURN_DEG = 20.0


@dataclass(frozen=True)
class Repeat:
    """One translation (working pixels, ``(rows, cols)``) under which the photo repeats, and its correlation there."""

    shift_px: tuple[float, float]
    correlation: float

    def as_record(self) -> dict[str, Any]:
        return {"shift_px": [round(float(v), 3) for v in self.shift_px], "correlation": round(float(self.correlation), 4)}


def autocorrelation(field: np.ndarray) -> np.ndarray:
    """Normalised linear autocorrelation of a zero-mean field, zero lag at the centre (each lag over its pixel pairs)."""
    f = np.asarray(field, dtype=np.float64)
    f = f - f.mean()
    n, m = f.shape
    padded = np.zeros((2 * n, 2 * m))
    padded[:n, :m] = f
    spec = np.fft.rfft2(padded)
    corr = np.fft.irfft2(spec * np.conj(spec), s=padded.shape)
    mask = np.zeros_like(padded)
    mask[:n, :m] = 1.0
    mspec = np.fft.rfft2(mask)
    pairs = np.fft.irfft2(mspec * np.conj(mspec), s=padded.shape)
    corr, pairs = np.fft.fftshift(corr), np.fft.fftshift(pairs)
    variance = float(np.mean(f * f))
    if not variance > 0:
        return np.zeros_like(corr)
    return corr / np.maximum(pairs, 1.0) / variance


def repeat_field(photo: np.ndarray) -> np.ndarray:
    """The photo's shading (dye layout divided out), with shading wider than :data:`HIGHPASS_PX` removed."""
    field = shading(np.asarray(photo, dtype=np.float64))
    return field - ndimage.gaussian_filter(field, HIGHPASS_PX, mode="reflect")


def photo_repeats(photo: np.ndarray) -> list[Repeat]:
    """Up to two translations (working pixels) under which the (H, W, 3) photo repeats; [] when it does not."""
    field = repeat_field(photo)
    corr = autocorrelation(field)
    centre = np.array(corr.shape) // 2
    rows, cols = np.indices(corr.shape)
    dy, dx = rows - centre[0], cols - centre[1]
    length = np.hypot(dy, dx)
    upper = (dy > 0) | ((dy == 0) & (dx > 0))  # a translation and its opposite are one repeat
    allowed = upper & (length >= MIN_SHIFT_PX) & (length <= MAX_SHIFT_FRACTION * min(field.shape))
    peaks = allowed & (corr == ndimage.maximum_filter(corr, size=3)) & np.isfinite(corr)
    if not peaks.any():
        return []
    best = float(corr[peaks].max())
    if best < MIN_CORRELATION:
        return []
    strong = np.flatnonzero(peaks & (corr >= STRONG_FRACTION * best))
    strong = strong[np.argsort(length.flat[strong])]
    chosen: list[int] = []
    for index in strong:
        if not chosen or all(_turn_deg(dy.flat[index], dx.flat[index], dy.flat[c], dx.flat[c]) >= MIN_TURN_DEG for c in chosen):
            chosen.append(int(index))
        if len(chosen) == 2:
            break
    return [Repeat(refined_shift(corr, int(dy.flat[i] + centre[0]), int(dx.flat[i] + centre[1]), centre), float(corr.flat[i]))
            for i in chosen]


def _turn_deg(ay: float, ax: float, by: float, bx: float) -> float:
    """Angle (degrees, in [0, 90]) between two translations, up to sign."""
    cosine = abs(ay * by + ax * bx) / max(np.hypot(ay, ax) * np.hypot(by, bx), 1e-12)
    return float(np.degrees(np.arccos(min(cosine, 1.0))))


def refined_shift(corr: np.ndarray, row: int, col: int, centre: np.ndarray) -> tuple[float, float]:
    """Sub-pixel position (rows, cols from zero lag) of an autocorrelation peak: a parabola through it on each axis."""
    def offset(minus: float, mid: float, plus: float) -> float:
        curvature = minus - 2.0 * mid + plus
        return float(np.clip(0.5 * (minus - plus) / curvature, -0.5, 0.5)) if curvature < 0 else 0.0
    r = row + offset(corr[row - 1, col], corr[row, col], corr[row + 1, col])
    c = col + offset(corr[row, col - 1], corr[row, col], corr[row, col + 1])
    return float(r - centre[0]), float(c - centre[1])


@dataclass(frozen=True)
class ShiftedSamples:
    """Bilinear gathers of a (size, size) map one translation away from each texel: flat indices, weights, validity."""

    indices: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    weights: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    mask: np.ndarray  # 1 / (texels whose translate lies on the map) there, else 0: the penalty is a mean over them
    weight: float  # the photo's correlation at the translation


def texel_shift(repeat: Repeat, size: int, photo_px: int, margin: float) -> tuple[float, float]:
    """A photo translation (working pixels) in texels of a ``size`` map that overhangs the view by ``margin``."""
    texels_per_pixel = size / (photo_px * (1.0 + margin))
    return repeat.shift_px[0] * texels_per_pixel, repeat.shift_px[1] * texels_per_pixel


def shifted_samples(size: int, shift: tuple[float, float], weight: float) -> ShiftedSamples:
    """:class:`ShiftedSamples` of the texel ``shift`` = (rows, cols) away from each texel of a (size, size) map."""
    rows, cols = np.meshgrid(np.arange(size, dtype=np.float64), np.arange(size, dtype=np.float64), indexing="ij")
    r, c = rows + shift[0], cols + shift[1]
    valid = (r >= 0) & (r <= size - 1) & (c >= 0) & (c <= size - 1)
    r0 = np.clip(np.floor(r), 0, size - 2).astype(np.int64)
    c0 = np.clip(np.floor(c), 0, size - 2).astype(np.int64)
    fr, fc = np.clip(r - r0, 0.0, 1.0), np.clip(c - c0, 0.0, 1.0)
    index = lambda dr, dc: ((r0 + dr) * size + (c0 + dc)).reshape(-1).astype(np.uint32)  # noqa: E731
    weights = ((1 - fr) * (1 - fc), (1 - fr) * fc, fr * (1 - fc), fr * fc)
    return ShiftedSamples((index(0, 0), index(0, 1), index(1, 0), index(1, 1)),
                          tuple(w.reshape(-1).astype(np.float32) for w in weights),
                          (valid / max(int(valid.sum()), 1)).reshape(-1).astype(np.float32), float(weight))


def repeat_samples(photo: np.ndarray, size: int, margin: float) -> tuple[list[ShiftedSamples], dict[str, Any]]:
    """The prior's gathers for a ``size`` texel map of the working ``photo``, and the record of what was found."""
    repeats = photo_repeats(photo)
    samples = [shifted_samples(size, texel_shift(r, size, photo.shape[0], margin), r.correlation) for r in repeats]
    reason = (f"photo repeats under {len(repeats)} translation(s)" if repeats
              else f"photo does not repeat (autocorrelation below {MIN_CORRELATION:g}): no repeat prior")
    return samples, {"repeats": [r.as_record() for r in repeats], "reason": reason}


def repeat_penalty_np(height: np.ndarray, samples: list[ShiftedSamples]) -> float:
    """The prior's value (before ``repeat_weight``) for a (size, size) height map, numpy version."""
    flat = height.reshape(-1)
    total = 0.0
    for s in samples:
        shifted = sum(w * flat[i] for i, w in zip(s.indices, s.weights))
        total += s.weight * float(np.sum(s.mask * (shifted - flat) ** 2))
    return total


def on_device(mi: ModuleType, samples: list[ShiftedSamples]) -> list[ShiftedSamples]:
    """``samples`` with their arrays as Dr.Jit arrays of the active variant (made once, read every iteration)."""
    return [ShiftedSamples(tuple(mi.UInt32(i) for i in s.indices), tuple(mi.Float(w) for w in s.weights),
                           mi.Float(s.mask), s.weight) for s in samples]


def repeat_penalty(mi: ModuleType, height: Any, samples: list[ShiftedSamples]) -> Any:
    """Differentiable :func:`repeat_penalty_np` of a flat height array (``samples`` from :func:`on_device`)."""
    total = 0.0
    for s in samples:
        shifted = sum(w * dr.gather(mi.Float, height, i) for i, w in zip(s.indices, s.weights))
        total = total + s.weight * dr.sum(s.mask * dr.square(shifted - height))
    return total
