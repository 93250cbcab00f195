"""Thread-structure descriptor of a scalar field: a fitted relief or shading, a true relief or a photo's luminance.

The paper's features (:mod:`clothscope.features.paper`) keep two peak radii and
heights of the normal map's z spectrum. This module describes the *lattice*
the threads form, in terms that are invariant by construction:

* **analysis window** (:func:`analysis_field`): the centred square minus a
  ``border`` fraction on each side (a fitted map's border is the edge of the
  optimisation region, where loss barely reaches and artefacts collect), with
  folds and shading removed by subtracting a wide Gaussian blur and the
  contrast normalised by the local RMS over the same width (colour, exposure
  and relief depth drop out);
* **fundamental** ``f0`` (:func:`find_lattice`): local maxima of the
  Hann-windowed power spectrum (smoothed 3x3) that stand ``peak_threshold``
  times above the median of their own ring (an isotropic background of any slope, such as fibre noise
  or a 1/f relief, scores about 1) and hold at least :data:`MIN_PEAK_SHARE` of the band's power; ``f0`` is the radius of the lowest peak
  holding at least ``fundamental_fraction`` of the strongest one's power, or,
  without a lattice (a pile), the power-weighted mean radius;
* **features** (:func:`structure_features`), all in units of ``f0`` or as
  ratios, so rotation, zoom, colour and smooth deformation leave them alone:

  - ``s_prof_1..10``: log10 share of the band power in ten log-spaced rings
    at 0.35-3.2 ``f0`` (a radial power profile in units of the fundamental);
  - ``s_prominence``: log10 ring-relative height of the strongest peak;
  - ``s_basis_ratio``, ``s_basis_angle``: shorter over longer basis vector of
    the lattice (the strongest peak and the strongest one at least 20 degrees
    away from it) and the angle between them in units of 90 degrees;
  - ``s_second_power``: log10 power of the second basis peak over the first;
  - ``s_n_peaks``: log(1 + number of lattice peaks within 3.2 ``f0``);
  - ``s_peak_fraction``: share of the band power in lattice peaks (woven
    lattices near 1, pile and fibre noise near 0);
  - ``s_coherence``: mean orientation coherence of the structure tensor at the
    canonical scale (floats and wales are directional);
  - ``s_kurtosis``, ``s_skew``: of the normalised field;
  - ``s_lbp_0..9``: uniform rotation-invariant local binary patterns
    (scikit-image, 8 neighbours at radius 2) after resampling the field so the
    fundamental period is ``CANONICAL_PERIOD`` pixels.

* **weave rings** (:func:`weave_rings`, ``w_*``): the normalised
  autocorrelation of that canonical field on circles of
  :data:`RING_PERIODS` thread periods, each summed up by angle-free numbers
  (largest, smallest and mean correlation on the circle, magnitudes of its
  second and fourth angular harmonics). A weave repeats after a few threads
  (a plain weave after two, a twill after three or four along a diagonal, a
  satin after five), which the LBP's quarter-period radius cannot see.

* **spectrum rings** (:func:`spectrum_rings`, ``p_*``): the canonical field's
  power spectrum on circles of :data:`SPECTRUM_RINGS` thread frequencies, each
  summed up by its log share of the power, its largest over its mean power and
  the magnitudes of its angular harmonics :data:`SPECTRUM_HARMONICS` over its
  mean: where the weave rings read the lattice in space, these read it in
  frequency, finer than the ten-ring radial profile and with the angles.

:func:`lbp_baseline` is the plain texture baseline of the feature-set report:
uniform LBP histograms at 8/1, 16/2 and 24/3 neighbours/radius on the analysis
window resampled to the canonical period (``lbp_scale: canonical``), or, with
``lbp_scale: pixels``, on the field as it is (no scale normalisation;
:func:`texture_columns`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import ndimage
from skimage.feature import local_binary_pattern

from clothscope.core.fourier import centred_spectrum, radius_grid, upper_half_plane

#: Ring centres of the radial profile, in units of the fundamental frequency.
PROFILE_RHO = np.geomspace(0.35, 3.2, 10)
#: Period (pixels) the field is resampled to before the local texture statistics.
CANONICAL_PERIOD = 8.0
#: Lowest frequency (bins) a lattice peak may have: longer periods are folds, not threads.
MIN_RADIUS_BINS = 3.0
#: Smallest analysis window (pixels per side) the descriptor accepts.
MIN_FIELD = 32
#: a lattice peak holds at least this share of the band's power: far below it, where a smoothed (fibre-noise)
#: spectrum has fallen by ten orders of magnitude, the Hann window's leakage along the axes stands above the
#: ring median and would read as peaks (workflow/benchmarks/noise_peaks.py)
MIN_PEAK_SHARE = 1e-7
#: Radii of the weave rings, in thread periods (one, the diagonal of a square cell, two threads, ...).
RING_PERIODS = (0.5, 1.0, 1.41, 1.5, 2.0, 2.24, 3.0)
#: Angles sampled on each weave ring.
RING_ANGLES = 72
#: Numbers kept per weave ring.
RING_STATISTICS = ("max", "min", "mean", "h2", "h4")
#: Radii of the spectrum rings, in thread frequencies (a weave repeat's peaks lie below 1, harmonics above).
SPECTRUM_RINGS = tuple(float(r) for r in np.linspace(0.25, 1.5, 11))
#: Angular harmonics kept per spectrum ring (the power spectrum is point symmetric: even ones only).
SPECTRUM_HARMONICS = (2, 4, 6)
#: (neighbours, radius) of the LBP baseline.
LBP_SCALES = ((8, 1), (16, 2), (24, 3))

STRUCTURE_COLUMNS = (
    *[f"s_prof_{k}" for k in range(1, len(PROFILE_RHO) + 1)],
    "s_prominence", "s_basis_ratio", "s_basis_angle", "s_second_power", "s_n_peaks", "s_peak_fraction",
    "s_sector_parallel", "s_sector_diagonal", "s_sector_across",
    "s_coherence", "s_kurtosis", "s_skew",
    *[f"s_lbp_{k}" for k in range(10)],
)
WEAVE_COLUMNS = tuple(f"w_{stat}_{k}" for k in range(1, len(RING_PERIODS) + 1) for stat in RING_STATISTICS)
SPECTRUM_COLUMNS = tuple(f"p_{stat}_{k}" for k in range(1, len(SPECTRUM_RINGS) + 1)
                         for stat in ("share", "peak", *(f"h{h}" for h in SPECTRUM_HARMONICS)))
LBP_COLUMNS = tuple(f"lbp_{p}_{r}_{k}" for p, r in LBP_SCALES for k in range(p + 2))
#: Columns a tile (:func:`clothscope.features.tiles.tile_columns`) re-describes; its image's row gives the others (the BSDF, the paper's features).
TILE_FEATURES = (*STRUCTURE_COLUMNS, *WEAVE_COLUMNS, *SPECTRUM_COLUMNS, *LBP_COLUMNS)
#: The structure descriptor of a fitted shade (albedo) texture: ``a_`` + each structure column.
SHADE_PREFIX = "a_"
SHADE_COLUMNS = tuple(SHADE_PREFIX + name for name in STRUCTURE_COLUMNS)


@dataclass(frozen=True)
class StructureSettings:
    """Knobs of the descriptor (``features.structure`` in the config schema, which holds the defaults)."""

    border: float
    peak_threshold: float
    fundamental_fraction: float
    lbp_scale: str


@dataclass(frozen=True)
class Lattice:
    """Peaks of a field's spectrum: flat indices sorted by power, and the fundamental radius."""

    peaks: np.ndarray
    f0: float
    found: bool


@dataclass(frozen=True)
class Spectrum:
    """Power spectrum of an analysis field with its smoothed, ring-relative version and bin coordinates."""

    power: np.ndarray
    smoothed: np.ndarray
    relative: np.ndarray
    radius: np.ndarray
    dy: np.ndarray
    dx: np.ndarray

    @property
    def size(self) -> int:
        return self.power.shape[0]


def analysis_field(field: np.ndarray, border: float) -> np.ndarray:
    """Centred square minus ``border`` on each side, large-scale shading removed, contrast normalised.

    Raises
    ------
    ValueError
        When the field is not 2-D, not finite, or too small once cropped.
    """
    f = np.asarray(field, dtype=np.float64)
    if f.ndim != 2:
        raise ValueError(f"expected a 2-D field, got shape {f.shape}")
    if not np.all(np.isfinite(f)):
        raise ValueError("the field holds non-finite values")
    f = window(f, border)
    if f.shape[0] < MIN_FIELD:
        raise ValueError(f"analysis window of {f.shape[0]} px is smaller than {MIN_FIELD} px")
    sigma = f.shape[0] / 10.0
    detail = f - ndimage.gaussian_filter(f, sigma, mode="reflect")
    envelope = np.sqrt(ndimage.gaussian_filter(detail**2, sigma, mode="reflect"))
    scale = float(envelope.mean())
    if scale <= 1e-12 * max(1.0, float(np.abs(f).max())):
        return np.zeros_like(detail)  # flat field: no structure
    return detail / (envelope + 1e-3 * scale)


def spectrum(field: np.ndarray) -> Spectrum:
    """Hann-windowed, centred power spectrum; smoothed 3x3 and divided by its ring medians."""
    power = np.abs(centred_spectrum(field, "hann")) ** 2
    dy, dx, radius = radius_grid(field.shape[0])
    smoothed = ndimage.uniform_filter(power, 3, mode="wrap")
    rings = np.rint(radius).astype(int)
    medians = ndimage.median(smoothed, labels=rings + 1, index=np.arange(1, rings.max() + 2))
    floor = np.asarray(medians)[rings]
    relative = smoothed / np.maximum(floor, 1e-30)
    return Spectrum(power, smoothed, relative, radius, dy, dx)


def find_lattice(s: Spectrum, settings: StructureSettings) -> Lattice:
    """Ring-relative peaks of one half-plane and the fundamental radius ``f0``."""
    band = (s.radius >= MIN_RADIUS_BINS) & (s.radius <= 0.45 * s.size) & upper_half_plane(s.dy, s.dx)
    local_max = s.smoothed == ndimage.maximum_filter(s.smoothed, 5, mode="wrap")
    audible = s.smoothed >= MIN_PEAK_SHARE * float(s.smoothed[band].sum())
    idx = np.flatnonzero(local_max & band & audible & (s.relative > settings.peak_threshold))
    peaks = idx[np.argsort(-s.smoothed.flat[idx], kind="stable")]
    if len(peaks):
        strongest = s.smoothed.flat[peaks[0]]
        fundamental = [int(k) for k in peaks if s.smoothed.flat[k] >= settings.fundamental_fraction * strongest]
        return Lattice(peaks, min(refined_radius(s, k) for k in fundamental), True)
    inside = (s.radius >= MIN_RADIUS_BINS) & (s.radius <= 0.45 * s.size)
    total = float(s.power[inside].sum())
    f0 = float((s.radius[inside] * s.power[inside]).sum() / total) if total > 0 else s.size / 8.0
    return Lattice(peaks, f0, False)


def refined_radius(s: Spectrum, index: int) -> float:
    """Radius of a peak refined to a fraction of a bin: the power-weighted centroid of its 5x5 neighbourhood."""
    row, col = divmod(index, s.size)
    rows = slice(max(row - 2, 0), row + 3)
    cols = slice(max(col - 2, 0), col + 3)
    weights = s.power[rows, cols]
    total = float(weights.sum())
    if total <= 0:
        return float(s.radius.flat[index])
    return float(np.hypot((weights * s.dy[rows, cols]).sum() / total, (weights * s.dx[rows, cols]).sum() / total))


def radial_profile(s: Spectrum, f0: float) -> np.ndarray:
    """log10 share of the band power (0.3-3.5 f0) in rings at :data:`PROFILE_RHO` times ``f0``."""
    nyquist = s.radius <= s.size / 2
    total = float(s.power[(s.radius >= 0.3 * f0) & (s.radius <= 3.5 * f0) & nyquist].sum())
    edges = np.sqrt(PROFILE_RHO[:-1] * PROFILE_RHO[1:])
    lows = np.r_[PROFILE_RHO[0] ** 2 / edges[0], edges]
    highs = np.r_[edges, PROFILE_RHO[-1] ** 2 / edges[-1]]
    shares = [float(s.power[(s.radius >= a * f0) & (s.radius < b * f0) & nyquist].sum()) / total if total > 0 else 0.0
              for a, b in zip(lows, highs)]
    return np.log10(np.asarray(shares) + 1e-6)


def folded_angle(delta: np.ndarray | float) -> np.ndarray | float:
    """Angle between undirected directions (radians), folded to [0, pi/2]."""
    return np.abs((delta + np.pi / 2) % np.pi - np.pi / 2)


def _direction(s: Spectrum, index: int) -> float:
    return float(np.arctan2(s.dy.flat[index], s.dx.flat[index]))


def _angle_between(s: Spectrum, a: int, b: int) -> float:
    """Angle between two peaks' directions, folded to [0, pi/2]."""
    return float(folded_angle(_direction(s, b) - _direction(s, a)))


def lattice_features(s: Spectrum, lattice: Lattice) -> dict[str, float]:
    """Basis ratio and angle, prominence, peak count and peak power share of a lattice (zeros without one)."""
    none = {"s_prominence": 0.0, "s_basis_ratio": 0.0, "s_basis_angle": 0.0, "s_second_power": -4.0,
            "s_n_peaks": 0.0, "s_peak_fraction": 0.0}
    if not lattice.found:
        return none
    first = int(lattice.peaks[0])
    second = next((int(k) for k in lattice.peaks[1:] if _angle_between(s, first, int(k)) > np.radians(20)), None)
    out = dict(none, s_prominence=float(np.log10(s.relative.flat[first])))
    if second is not None:
        r1, r2 = s.radius.flat[first], s.radius.flat[second]
        out["s_basis_ratio"] = float(min(r1, r2) / max(r1, r2))
        out["s_basis_angle"] = _angle_between(s, first, second) / (np.pi / 2)
        out["s_second_power"] = float(np.log10(max(s.smoothed.flat[second] / s.smoothed.flat[first], 1e-4)))
    within = [int(k) for k in lattice.peaks if s.radius.flat[k] <= 3.2 * lattice.f0]
    out["s_n_peaks"] = float(np.log1p(len(within)))
    mask = np.zeros(s.power.shape, dtype=bool)
    mask.flat[within] = True
    mask = ndimage.binary_dilation(mask, iterations=1)
    band = (s.radius >= 0.3 * lattice.f0) & (s.radius <= 3.2 * lattice.f0) & upper_half_plane(s.dy, s.dx)
    total = float(s.power[band].sum())
    out["s_peak_fraction"] = float(s.power[mask & band].sum() / total) if total > 0 else 0.0
    return out


def sector_shares(s: Spectrum, lattice: Lattice) -> dict[str, float]:
    """Shares of the band power (0.5-2.5 f0) parallel to, diagonal to and across the dominant direction.

    The dominant direction is the strongest lattice peak's, or without a
    lattice the most powerful of 36 angular sectors. Angles are folded to
    [0, 90] degrees from it: parallel below 22.5, across above 67.5.
    """
    band = (s.radius >= 0.5 * lattice.f0) & (s.radius <= 2.5 * lattice.f0) & (s.radius <= s.size / 2)
    angles = np.arctan2(s.dy[band], s.dx[band])
    power = s.power[band]
    total = float(power.sum())
    if total <= 0:
        return {"s_sector_parallel": 0.0, "s_sector_diagonal": 0.0, "s_sector_across": 0.0}
    if lattice.found:
        reference = _direction(s, int(lattice.peaks[0]))
    else:
        sectors = np.bincount(((angles % np.pi) / np.pi * 36).astype(int) % 36, weights=power, minlength=36)
        reference = (int(np.argmax(sectors)) + 0.5) * np.pi / 36
    folded = folded_angle(angles - reference)
    return {"s_sector_parallel": float(power[folded < np.radians(22.5)].sum() / total),
            "s_sector_diagonal": float(power[(folded >= np.radians(22.5)) & (folded <= np.radians(67.5))].sum() / total),
            "s_sector_across": float(power[folded > np.radians(67.5)].sum() / total)}


def canonical_field(field: np.ndarray, f0: float) -> np.ndarray:
    """The field resampled so that its fundamental period is :data:`CANONICAL_PERIOD` pixels."""
    period = field.shape[0] / f0
    zoom = CANONICAL_PERIOD / period
    if abs(zoom - 1.0) < 1e-3:
        return field
    return ndimage.zoom(field, zoom, order=1, mode="reflect", grid_mode=True)


def texture_features(canonical: np.ndarray, field: np.ndarray) -> dict[str, float]:
    """Orientation coherence, kurtosis, skewness and LBP 8/2 histogram at the canonical scale."""
    gy = ndimage.gaussian_filter(canonical, 1.0, order=(1, 0))
    gx = ndimage.gaussian_filter(canonical, 1.0, order=(0, 1))
    jxx, jxy, jyy = (ndimage.gaussian_filter(a, CANONICAL_PERIOD / 2) for a in (gx * gx, gx * gy, gy * gy))
    trace = jxx + jyy
    spread = np.sqrt((jxx - jyy) ** 2 + 4 * jxy**2)
    coherence = float(np.mean(spread / np.maximum(trace, 1e-12))) if trace.max() > 1e-12 else 0.0
    m2 = float(np.mean(field**2))
    out = {"s_coherence": coherence,
           "s_kurtosis": float(np.mean(field**4) / m2**2) if m2 > 1e-12 else 0.0,
           "s_skew": float(np.mean(field**3) / m2**1.5) if m2 > 1e-12 else 0.0}
    histogram = lbp_histogram(canonical, 8, 2)
    out.update({f"s_lbp_{k}": float(v) for k, v in enumerate(histogram)})
    return out


def autocorrelation(field: np.ndarray) -> np.ndarray:
    """Normalised autocorrelation of a field, lag (0, 0) at the centre of a (2H, 2W) array; zeros for a flat field.

    Linear, not circular: the field is zero-padded and each lag's sum is divided
    by the number of pixel pairs it holds, so the value at a lag is the mean
    product of pixels that far apart over the variance.
    """
    f = np.asarray(field, dtype=np.float64)
    f = f - f.mean()
    shape = (2 * f.shape[0], 2 * f.shape[1])
    products = np.fft.irfft2(np.abs(np.fft.rfft2(f, s=shape)) ** 2, s=shape)
    pairs = np.fft.irfft2(np.abs(np.fft.rfft2(np.ones_like(f), s=shape)) ** 2, s=shape)
    acf = np.fft.fftshift(products / np.maximum(pairs, 1.0))
    variance = acf[f.shape[0], f.shape[1]]
    return acf / variance if variance > 1e-12 else np.zeros_like(acf)


def weave_rings(canonical: np.ndarray) -> dict[str, float]:
    """The ``w_*`` columns: the canonical field's autocorrelation on circles of :data:`RING_PERIODS` periods.

    Per circle (:data:`RING_ANGLES` bilinear samples) the largest, smallest and
    mean correlation and the magnitudes of the second and fourth angular
    harmonics; all five are unchanged by a rotation of the field. A circle wider
    than 0.45 of the field's side reads zeros.
    """
    acf = autocorrelation(canonical)
    cy, cx = canonical.shape[0], canonical.shape[1]
    angles = np.arange(RING_ANGLES) * 2 * np.pi / RING_ANGLES
    out: dict[str, float] = {}
    for k, periods in enumerate(RING_PERIODS, start=1):
        radius = periods * CANONICAL_PERIOD
        if radius > 0.45 * min(canonical.shape):
            ring = np.zeros(RING_ANGLES)
        else:
            ring = ndimage.map_coordinates(acf, [cy + radius * np.sin(angles), cx + radius * np.cos(angles)], order=1)
        harmonics = np.abs(np.fft.rfft(ring)) / RING_ANGLES
        values = (ring.max(), ring.min(), ring.mean(), harmonics[2], harmonics[4])
        out.update({f"w_{stat}_{k}": float(v) for stat, v in zip(RING_STATISTICS, values)})
    return out


def half_circle(values: np.ndarray, radius: float) -> np.ndarray:
    """``values`` (centred on its middle pixel) on a half circle of ``radius`` pixels, :data:`RING_ANGLES` bilinear
    samples: enough for a point-symmetric map, whose full-circle harmonic ``h`` is the half circle's ``h // 2``."""
    centre = values.shape[0] // 2
    angles = np.linspace(0, np.pi, RING_ANGLES, endpoint=False)
    return ndimage.map_coordinates(values, [centre + radius * np.sin(angles), centre + radius * np.cos(angles)], order=1)


def spectrum_rings(canonical: np.ndarray) -> dict[str, float]:
    """The ``p_*`` columns: the canonical field's power spectrum on circles of :data:`SPECTRUM_RINGS` thread frequencies.

    The spectrum is that of the centred square (mean removed, Hann window), smoothed
    3x3. Per circle: ``p_share``, log10 of its mean power over the mean power of the
    whole spectrum; ``p_peak``, log10 of its largest over its mean power; ``p_h2``,
    ``p_h4``, ``p_h6``, the magnitudes of those angular harmonics over its mean power.
    All are unchanged by a rotation or a rescaling of the field's values; a flat field
    reads ``p_share`` at -9 and every other column at 0.
    """
    side = min(canonical.shape)
    square = np.asarray(canonical, dtype=np.float64)[:side, :side]
    if np.ptp(square) <= 1e-12 * max(1.0, float(np.abs(square).max())):  # a flat field: no power on any ring
        return {name: -9.0 if name.startswith("p_share_") else 0.0 for name in SPECTRUM_COLUMNS}
    square = square - square.mean()
    hann = np.outer(np.hanning(side), np.hanning(side))
    power = ndimage.uniform_filter(np.fft.fftshift(np.abs(np.fft.fft2(square * hann)) ** 2), 3)
    total = float(power.sum())
    out: dict[str, float] = {}
    for k, rho in enumerate(SPECTRUM_RINGS, start=1):
        ring = half_circle(power, rho * side / CANONICAL_PERIOD)
        mean = float(ring.mean()) + 1e-30
        harmonics = np.abs(np.fft.rfft(ring)) / (len(ring) * mean)
        out[f"p_share_{k}"] = float(np.log10(mean * side * side / total + 1e-9))
        out[f"p_peak_{k}"] = float(np.log10(float(ring.max()) / mean + 1e-9))
        out |= {f"p_h{h}_{k}": float(harmonics[h // 2]) for h in SPECTRUM_HARMONICS}
    return {name: float(np.nan_to_num(out[name], nan=0.0, posinf=0.0, neginf=0.0)) for name in SPECTRUM_COLUMNS}


def lbp_histogram(field: np.ndarray, neighbours: int, radius: float) -> np.ndarray:
    """Normalised histogram of uniform rotation-invariant LBP codes (``neighbours + 2`` bins)."""
    image = np.asarray(field, dtype=np.float64)
    if image.shape[0] <= 2 * radius + 1 or image.shape[1] <= 2 * radius + 1:
        return np.zeros(neighbours + 2)
    low, high = float(image.min()), float(image.max())
    levels = np.zeros(image.shape, np.uint8) if high - low <= 0 else np.rint((image - low) / (high - low) * 255).astype(np.uint8)
    codes = local_binary_pattern(levels, neighbours, radius, method="uniform").astype(int)
    counts = np.bincount(codes.ravel(), minlength=neighbours + 2)[: neighbours + 2].astype(np.float64)
    return counts / counts.sum()


def with_period(lattice: Lattice, size: int, period_px: float | None) -> Lattice:
    """``lattice`` with its fundamental set to ``size / period_px`` bins; unchanged without a period or when that
    frequency lies outside the band a lattice peak may have (:data:`MIN_RADIUS_BINS` to 0.45 ``size``)."""
    if period_px is None or not np.isfinite(period_px) or period_px <= 0:
        return lattice
    f0 = size / float(period_px)
    return Lattice(lattice.peaks, f0, lattice.found) if MIN_RADIUS_BINS <= f0 <= 0.45 * size else lattice


def structure_features(field: np.ndarray, settings: StructureSettings,
                       period_px: float | None = None) -> tuple[dict[str, float], dict[str, Any]]:
    """The ``s_*`` columns of one field, and diagnostics (``f0``, period, lattice found, profile).

    Parameters
    ----------
    field
        2-D relief (height map), shading or luminance, any real values.
    settings
        Analysis window and peak test.
    period_px
        Thread period in the field's pixels measured elsewhere (:func:`with_period`); None: the
        field's own fundamental.

    Returns
    -------
    features, diagnostics
        ``features`` holds every name of :data:`STRUCTURE_COLUMNS`, all finite;
        ``diagnostics`` holds ``f0`` (bins), ``period_px`` (analysis-field
        pixels), ``lattice`` (bool), ``size``, ``profile`` and ``canonical`` (the
        analysis field resampled so its period is :data:`CANONICAL_PERIOD` pixels).

    Raises
    ------
    ValueError
        On a field that is not 2-D, not finite or too small.
    """
    f = analysis_field(field, settings.border)
    s = spectrum(f)
    lattice = with_period(find_lattice(s, settings), f.shape[0], period_px)
    profile = radial_profile(s, lattice.f0)
    features = {f"s_prof_{k}": float(v) for k, v in enumerate(profile, start=1)}
    features.update(lattice_features(s, lattice))
    features.update(sector_shares(s, lattice))
    canonical = canonical_field(f, lattice.f0)
    features.update(texture_features(canonical, f))
    features = {name: float(np.nan_to_num(features[name], nan=0.0, posinf=0.0, neginf=0.0)) for name in STRUCTURE_COLUMNS}
    diagnostics = {"f0": lattice.f0, "period_px": f.shape[0] / lattice.f0, "lattice": lattice.found, "size": f.shape[0],
                   "profile": profile.tolist(), "canonical": canonical}
    return features, diagnostics


def texture_columns(field: np.ndarray, settings: StructureSettings, period_px: float | None = None) -> dict[str, float]:
    """The ``s_*``, ``w_*``, ``p_*`` and ``lbp_*`` columns of one field (``period_px``: as :func:`structure_features`).

    ``settings.lbp_scale`` says where the ``lbp_*`` histograms are taken:
    ``pixels``, the field as it is (the plain baseline; it moves with the
    photo's zoom), or ``canonical``, the analysis field resampled so its
    thread period is :data:`CANONICAL_PERIOD` pixels (scale invariant).
    """
    if settings.lbp_scale not in ("pixels", "canonical"):
        raise ValueError(f"lbp_scale must be 'pixels' or 'canonical', got {settings.lbp_scale!r}")
    features, diagnostics = structure_features(field, settings, period_px)
    rings = weave_rings(diagnostics["canonical"]) | spectrum_rings(diagnostics["canonical"])
    return features | rings | lbp_baseline(diagnostics["canonical"] if settings.lbp_scale == "canonical" else field)


def window(field: np.ndarray, border: float) -> np.ndarray:
    """The centred square of ``field`` minus ``border`` of its side on each side (as it is, not normalised)."""
    f = np.asarray(field, dtype=np.float64)
    n = min(f.shape)
    r0, c0 = (f.shape[0] - n) // 2, (f.shape[1] - n) // 2
    b = int(round(border * n))
    return f[r0 + b : r0 + n - b, c0 + b : c0 + n - b]


def shade_features(shade: np.ndarray | None, settings: StructureSettings) -> dict[str, float]:
    """The :data:`SHADE_COLUMNS` of a fitted shade texture; all zero without one (a map of one colour)."""
    if shade is None:
        return dict.fromkeys(SHADE_COLUMNS, 0.0)
    return {SHADE_PREFIX + name: value for name, value in structure_features(shade, settings)[0].items()}


def lbp_baseline(field: np.ndarray) -> dict[str, float]:
    """The ``lbp_*`` columns: uniform LBP histograms at :data:`LBP_SCALES` of the field as it is."""
    image = np.asarray(field, dtype=np.float64)
    if image.ndim != 2 or not np.all(np.isfinite(image)):
        raise ValueError("the LBP baseline needs a finite 2-D field")
    out: dict[str, float] = {}
    for neighbours, radius in LBP_SCALES:
        for k, v in enumerate(lbp_histogram(image, neighbours, radius)):
            out[f"lbp_{neighbours}_{radius}_{k}"] = float(v)
    return out
