"""Fourier-spectrum features of a fitted normal map (paper sections 3.3-3.4, Algorithm 2).

The thread structure of a cloth shows up as peaks in the 2-D Fourier spectrum
of the z component of its tangent-space normal map. :func:`analyse_normal_map`
follows Algorithm 2 of the paper:

1. take ``Z``, the z component of the normal map;
2. subtract its mean, apply a 2-D Hann window (optional) and take the centred
   FFT **magnitude** ``|F|`` (not the power: the paper's Figure 3 shows the
   magnitude in log scale, and the noise floor statistics below are less
   dominated by a few bright peaks on the magnitude scale);
3. zero a disc of radius ``dc_radius`` around DC (large-scale ripples);
4. mean-filter the spectrum at the peak size (``scipy.ndimage.uniform_filter``);
5. noise floor = mean and standard deviation of the filtered spectrum over the
   *analysis annulus* (outside the DC disc and inside the inscribed Nyquist
   circle ``r <= N/2``); plain mean/std as in the paper, not median/MAD: the
   spectra of woven cloth are heavy-tailed, and a robust floor declares
   hundreds of harmonics and aliases "peaks", which makes ``n_peaks`` unstable;
6. peaks = local maxima (``maximum_filter`` at the peak size) of the filtered
   spectrum more than ``alpha`` standard deviations above the floor, inside
   the annulus and in one half-plane only (the spectrum of a real map is
   point-symmetric, so every peak has a mirror twin that must not be counted);
7. polar coordinates, angle dropped, radius truncated to an integer; peaks
   sharing a truncated radius are merged keeping the highest one;
8. radii are normalised by a reference radius: the paper's ``R_m`` (largest
   radius) or, by default here, a robust variant that uses the strong peaks
   only (``strong_fraction`` of the highest peak's height);
9. peaks sorted by height (descending), then radius (ascending), heights
   normalised by the largest, and the first
   ``n_peaks`` are kept, padded with zeros.

The choices the paper leaves open (units of the DC radius and peak size, the annulus,
normalised heights, ordering, sub-bin radii) and the strong-peak definitions used by
default are explained in docs/design.md, "Algorithm 2: what the paper leaves open".

Extra features are in :mod:`clothscope.features.extras`, the thread period in
:mod:`clothscope.features.period` and the figures in :mod:`clothscope.features.plots`.
The module is over 400 lines because it holds one algorithm, Algorithm 2, whole.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import ndimage

from clothscope.core.fourier import centred_spectrum, radius_grid, upper_half_plane

#: Smallest accepted normal-map side, in texels.
MIN_SIZE = 16
#: Peak-to-peak variation of the z map below which the map counts as flat.
FLAT_TOLERANCE = 1e-9
#: Fewest spectrum bins a ring of the noise-calibrated peak test holds (:func:`ring_noise_threshold`).
MIN_RING_BINS = 64


@dataclass(frozen=True)
class SpectrumSettings:
    """Knobs of the normal-map spectrum analysis (``features:`` in the config schema, which holds the defaults).

    Parameters
    ----------
    n_peaks : int
        Number of peaks kept as features (``r_1..r_n``, ``z_1..z_n``).
    alpha : float
        Peaks must stand this many floor standard deviations above the floor mean.
    dc_radius : float
        Radius of the disc zeroed around DC, in frequency bins at ``reference_resolution``.
    peak_size : float
        Mean-filter and local-maximum window, in frequency bins at ``reference_resolution``.
    window : str
        ``"hann"`` (2-D separable Hann window before the FFT) or ``"none"``.
    reference_resolution : int
        Normal-map width (texels) at which ``dc_radius`` and ``peak_size`` are
        given; both are scaled by ``N / reference_resolution`` for an N-texel
        map. 1024 is a documented guess (see the module docstring).
    radius_normalisation : str
        What the peak radii are divided by: ``"strong_max"`` (the schema default) the
        largest radius among the *strong* peaks, those at least
        ``strong_fraction`` as high as the highest; ``"max"`` the largest
        radius among all peaks found (the paper's ``R_m``); ``"strongest"``
        the radius of the highest peak (so ``r_1 == 1``).
    peak_count : str
        The ``n_peaks`` feature: ``"strong"`` (the schema default) the number of strong
        peaks; ``"all"`` the number of all peaks found (the paper's ``|S|``).
    strong_fraction : float
        In (0, 1]: a peak is strong when its height is at least this fraction
        of the highest peak's (heights above the floor mean, in floor standard
        deviations). Used by ``"strong_max"`` and ``"strong"`` only.
    significance : float
        A peak must also stand this many robust standard deviations (1.4826 x
        MAD) above the median of its own ring of the filtered spectrum
        (:func:`significant_peaks`), which calibrates the test against the
        map's own noise, whatever its colour: at 6, white or smoothed noise maps
        of 64-512 texels give under one false peak each on average
        (``tests/test_spectrum.py`` bounds it), where the paper's test finds
        dozens. 0 (the schema default) turns the test off: the paper's Algorithm 2 (see
        docs/design.md for why it is not on by default).

    ``radius_normalisation="max", peak_count="all", significance=0`` is the
    paper-faithful Algorithm 2 (:meth:`paper` returns such settings).
    """

    n_peaks: int
    alpha: float
    dc_radius: float
    peak_size: float
    window: str
    reference_resolution: int
    radius_normalisation: str
    peak_count: str
    strong_fraction: float
    significance: float

    def paper(self) -> SpectrumSettings:
        """These settings with the paper's ``R_m`` normalisation and peak count, and no noise-calibrated test."""
        return replace(self, radius_normalisation="max", peak_count="all", significance=0.0)

    def dc_radius_bins(self, size: int) -> float:
        """DC-disc radius in frequency bins for a ``size``-texel map."""
        return self.dc_radius * size / self.reference_resolution

    def peak_size_bins(self, size: int) -> int:
        """Filter window for a ``size``-texel map: the scaled peak size rounded to an odd integer >= 1."""
        scaled = self.peak_size * size / self.reference_resolution
        return max(1, 2 * int(math.floor((scaled - 1.0) / 2.0 + 0.5)) + 1)


@dataclass(frozen=True)
class Peak:
    """One spectral peak, in the half-plane kept by the analysis.

    Attributes
    ----------
    row, col : float
        Refined position in the centred spectrum (DC at ``(N // 2, N // 2)``), in bins.
    radius_bins : float
        Distance from DC in frequency bins (cycles per map width).
    radius : int
        ``radius_bins`` truncated to an integer, as in Algorithm 2.
    radius_norm : float
        ``radius / R`` with ``R`` set by ``SpectrumSettings.radius_normalisation``
        (the paper's ``R_m``, the largest radius among all peaks found, with
        ``"max"``); in (0, 1] for ``"max"`` and for the strong peaks under
        ``"strong_max"``, may exceed 1 otherwise.
    height : float
        Normalised height: filtered-spectrum height above the noise-floor mean
        divided by that of the highest peak found, in (0, 1].
    snr : float
        Filtered-spectrum height above the noise floor, in floor standard deviations.
    angle_deg : float
        Direction of the peak, in degrees in [0, 180).
    """

    row: float
    col: float
    radius_bins: float
    radius: int
    radius_norm: float
    height: float
    snr: float
    angle_deg: float


@dataclass
class SpectrumResult:
    """Everything :func:`analyse_normal_map` computed, for features and plots.

    Attributes
    ----------
    z_map : numpy.ndarray
        (N, N) z component as analysed (before mean removal and windowing).
    log_spectrum : numpy.ndarray
        ``log1p(|F|)`` of the centred spectrum, before DC removal.
    filtered_spectrum : numpy.ndarray
        ``|F|`` after DC removal and mean filtering (the spectrum peaks are found in).
    peaks : tuple of Peak
        The chosen peaks, at most ``settings.n_peaks``, in feature order.
    candidates : tuple of Peak
        Every peak after merging by integer radius, in feature order.
    features : dict of str to float
        ``r_1..r_n``, ``z_1..z_n`` and ``n_peaks``.
    dominant_period_px : float or None
        Map width divided by the radius (bins) of the strongest peak, in texels.
    settings : SpectrumSettings
        The settings used.
    dc_radius_bins : float
        The DC-disc radius used, in bins.
    peak_size_bins : int
        The filter window used, in bins.
    floor_mean, floor_std : float
        Noise floor of the filtered spectrum over the analysis annulus.
    magnitude : numpy.ndarray
        ``|F|`` after DC removal, before filtering.
    raw_peaks : tuple of Peak
        Every peak before merging by radius, strongest first (for angles).
    """

    z_map: np.ndarray
    log_spectrum: np.ndarray
    filtered_spectrum: np.ndarray
    peaks: tuple[Peak, ...]
    candidates: tuple[Peak, ...]
    features: dict[str, float]
    dominant_period_px: float | None
    settings: SpectrumSettings
    dc_radius_bins: float
    peak_size_bins: int
    floor_mean: float
    floor_std: float
    magnitude: np.ndarray = field(repr=False, default_factory=lambda: np.zeros((0, 0)))
    raw_peaks: tuple[Peak, ...] = ()


def z_component(normal: np.ndarray) -> np.ndarray:
    """Validated (N, N) float64 z map of an (N, N, 3) normal map or an (N, N) z map.

    Raises
    ------
    ValueError
        On a wrong shape, a non-square or too small map, or NaN / infinite values.
    """
    array = np.asarray(normal)
    if array.ndim == 3 and array.shape[-1] == 3:
        z = array[..., 2]
    elif array.ndim == 2:
        z = array
    else:
        raise ValueError(f"normal map must have shape (H, W, 3) or (H, W), got {array.shape}")
    if not np.issubdtype(z.dtype, np.number) or np.issubdtype(z.dtype, np.complexfloating):
        raise ValueError(f"normal map must hold real numbers, got dtype {z.dtype}")
    height, width = z.shape
    if height != width:
        raise ValueError(f"normal map must be square, got {height}x{width}; crop it to a square first")
    if height < MIN_SIZE:
        raise ValueError(f"normal map is {height}x{width}, smaller than the minimum of {MIN_SIZE}x{MIN_SIZE}")
    z = z.astype(np.float64)
    if not np.all(np.isfinite(z)):
        raise ValueError("normal map contains NaN or infinite values")
    return z


def magnitude_spectrum(z: np.ndarray, window: str) -> np.ndarray:
    """Centred FFT magnitude of the mean-free, windowed z map (zeros for a flat map)."""
    if np.ptp(z) < FLAT_TOLERANCE:
        return np.zeros_like(z, dtype=np.float64)
    return np.abs(centred_spectrum(z, window))


def noise_floor(filtered: np.ndarray, annulus: np.ndarray) -> tuple[float, float]:
    """Mean and standard deviation of the filtered spectrum over the annulus (0, 0 if empty)."""
    values = filtered[annulus]
    if values.size == 0:
        return 0.0, 0.0
    return float(values.mean()), float(values.std())


def refine_peak(magnitude: np.ndarray, row: int, col: int, half: int) -> tuple[float, float]:
    """Sub-bin position: power centroid of a 3x3 window around the largest bin near ``(row, col)``.

    The largest unfiltered bin is searched within ``half`` bins of the filtered
    maximum; the spectrum is treated as periodic.
    """
    size = magnitude.shape[0]
    rows = np.arange(row - half, row + half + 1) % size
    cols = np.arange(col - half, col + half + 1) % size
    patch = magnitude[np.ix_(rows, cols)]
    i, j = np.unravel_index(int(np.argmax(patch)), patch.shape)
    centre_r, centre_c = row - half + int(i), col - half + int(j)
    offsets = np.array([-1, 0, 1])
    weights = magnitude[np.ix_((centre_r + offsets) % size, (centre_c + offsets) % size)] ** 2
    total = weights.sum()
    if not np.isfinite(total) or total <= 0:
        return float(row), float(col)
    return float(centre_r + (weights.sum(axis=1) @ offsets) / total), float(centre_c + (weights.sum(axis=0) @ offsets) / total)


def find_peaks(filtered: np.ndarray, candidates_mask: np.ndarray, size: int, threshold: float) -> np.ndarray:
    """(K, 2) integer positions of local maxima (window ``size``) above ``threshold`` inside the mask."""
    local_max = filtered == ndimage.maximum_filter(filtered, size=size, mode="wrap")
    return np.argwhere(local_max & candidates_mask & (filtered > threshold))


def ring_noise_threshold(filtered: np.ndarray, radius: np.ndarray, annulus: np.ndarray, width: int,
                         significance: float) -> np.ndarray:
    """Per-bin threshold: median + ``significance`` x 1.4826 MAD of the filtered spectrum in the bin's ring.

    Rings are ``width`` bins wide, widened outwards until each holds at least
    :data:`MIN_RING_BINS` bins (so that a peak never makes up most of its own
    ring); outside the annulus the threshold is infinite.
    """
    ring = np.floor(radius[annulus] / width).astype(int)
    values = filtered[annulus]
    inside = np.empty(values.shape)
    start = None
    for index, k in enumerate(rings := np.unique(ring)):
        start = k if start is None else start
        members = (ring >= start) & (ring <= k)
        if members.sum() < MIN_RING_BINS and index < len(rings) - 1:
            continue
        median = float(np.median(values[members]))
        spread = 1.4826 * float(np.median(np.abs(values[members] - median)))
        inside[members] = median + significance * spread
        start = None
    threshold = np.full(filtered.shape, np.inf)
    threshold[annulus] = inside
    return threshold


def significant_peaks(positions: np.ndarray, filtered: np.ndarray, radius: np.ndarray, annulus: np.ndarray, width: int,
                      significance: float) -> np.ndarray:
    """The ``positions`` that stand above their ring's noise (:func:`ring_noise_threshold`); all of them at 0."""
    if significance <= 0 or len(positions) == 0:
        return positions
    threshold = ring_noise_threshold(filtered, radius, annulus, width, significance)
    keep = filtered[positions[:, 0], positions[:, 1]] > threshold[positions[:, 0], positions[:, 1]]
    return positions[keep]


def merge_by_radius(peaks: list[Peak]) -> list[Peak]:
    """Keep, for each integer radius, the highest peak (Algorithm 2's set ``S``)."""
    best: dict[int, Peak] = {}
    for peak in peaks:
        if peak.radius not in best or peak.snr > best[peak.radius].snr:
            best[peak.radius] = peak
    return list(best.values())


def order_peaks(peaks: list[Peak]) -> list[Peak]:
    """Feature order: height descending, then radius ascending."""
    return sorted(peaks, key=lambda p: (-p.snr, p.radius_bins))


def peak_features(peaks: list[Peak], n: int, found: int) -> dict[str, float]:
    """``r_1..r_n`` (normalised radii), ``z_1..z_n`` (heights) padded with zeros, and ``n_peaks``."""
    features: dict[str, float] = {}
    for k in range(n):
        peak = peaks[k] if k < len(peaks) else None
        features[f"r_{k + 1}"] = float(peak.radius_norm) if peak else 0.0
    for k in range(n):
        peak = peaks[k] if k < len(peaks) else None
        features[f"z_{k + 1}"] = float(peak.height) if peak else 0.0
    features["n_peaks"] = float(found)
    return features


def _build_peaks(
    positions: np.ndarray, magnitude: np.ndarray, filtered: np.ndarray, floor: tuple[float, float], half: int
) -> list[Peak]:
    """Peak records (not yet normalised) of the integer maxima ``positions``."""
    size = magnitude.shape[0]
    mean, std = floor
    peaks = []
    for row, col in positions:
        r_row, r_col = refine_peak(magnitude, int(row), int(col), half)
        dy, dx = r_row - size // 2, r_col - size // 2
        radius_bins = float(math.hypot(dy, dx))
        snr = (float(filtered[row, col]) - mean) / std
        angle = math.degrees(math.atan2(-dy, dx)) % 180.0
        peaks.append(Peak(r_row, r_col, radius_bins, int(radius_bins), 0.0, snr, snr, angle))
    return peaks


def reference_radius(peaks: list[Peak], normalisation: str, strong_fraction: float) -> int:
    """The radius ``R`` the peak radii are divided by (0 without peaks).

    ``"max"``: largest integer radius of all peaks (the paper's ``R_m``);
    ``"strong_max"``: largest integer radius of the strong peaks (height at
    least ``strong_fraction`` of the highest); ``"strongest"``: integer radius
    of the highest peak (ties: the smaller radius).
    """
    if not peaks:
        return 0
    if normalisation == "max":
        return max(p.radius for p in peaks)
    snr_max = max(p.snr for p in peaks)
    if normalisation == "strong_max":
        return max(p.radius for p in peaks if p.snr >= strong_fraction * snr_max)
    if normalisation == "strongest":
        return min(peaks, key=lambda p: (-p.snr, p.radius_bins)).radius
    raise ValueError(f"unknown radius_normalisation {normalisation!r}")


def count_peaks(peaks: list[Peak], mode: str, strong_fraction: float) -> int:
    """The ``n_peaks`` feature: all merged peaks (``"all"``) or the strong ones (``"strong"``)."""
    if mode == "all" or not peaks:
        return len(peaks)
    if mode == "strong":
        snr_max = max(p.snr for p in peaks)
        return sum(1 for p in peaks if p.snr >= strong_fraction * snr_max)
    raise ValueError(f"unknown peak_count {mode!r}")


def _normalise(peaks: list[Peak], normalisation: str, strong_fraction: float) -> list[Peak]:
    """Set ``radius_norm = radius / R`` (:func:`reference_radius`) and ``height = snr / max snr``."""
    r_max = reference_radius(peaks, normalisation, strong_fraction)
    snr_max = max((p.snr for p in peaks), default=0.0)
    return [
        Peak(p.row, p.col, p.radius_bins, p.radius, p.radius / r_max if r_max > 0 else 0.0,
             p.snr / snr_max if snr_max > 0 else 0.0, p.snr, p.angle_deg)
        for p in peaks
    ]


def analyse_normal_map(normal: np.ndarray, settings: SpectrumSettings) -> SpectrumResult:
    """Run Algorithm 2 on one normal map.

    Parameters
    ----------
    normal : numpy.ndarray
        (N, N, 3) tangent-space unit normals (z up) or an (N, N) z map; N >= 16.
    settings : SpectrumSettings
        Peak-finding settings.

    Returns
    -------
    SpectrumResult
        Spectra, peaks and the features ``r_1..r_n``, ``z_1..z_n``, ``n_peaks``.
        Flat, noisy or non-periodic maps give few or no peaks and zero-padded,
        finite features.

    Raises
    ------
    ValueError
        If the map has the wrong shape, is not square, is smaller than 16x16,
        or holds NaN or infinite values.
    """
    z = z_component(normal)
    size = z.shape[0]
    magnitude = magnitude_spectrum(z, settings.window)
    log_spectrum = np.log1p(magnitude)
    dy, dx, radius = radius_grid(size)
    dc_bins = settings.dc_radius_bins(size)
    peak_bins = settings.peak_size_bins(size)
    magnitude[radius < dc_bins] = 0.0
    filtered = ndimage.uniform_filter(magnitude, size=peak_bins, mode="wrap")
    annulus = (radius >= dc_bins) & (radius <= size / 2)
    floor = noise_floor(filtered, annulus)
    raw: list[Peak] = []
    if floor[1] > 0 and np.isfinite(floor[1]):
        positions = find_peaks(filtered, annulus & upper_half_plane(dy, dx), peak_bins, floor[0] + settings.alpha * floor[1])
        positions = significant_peaks(positions, filtered, radius, annulus, max(2, peak_bins), settings.significance)
        raw = _build_peaks(positions, magnitude, filtered, floor, max(1, peak_bins // 2))
    candidates = order_peaks(_normalise(merge_by_radius(raw), settings.radius_normalisation, settings.strong_fraction))
    chosen = candidates[: settings.n_peaks]
    dominant = size / chosen[0].radius_bins if chosen and chosen[0].radius_bins > 0 else None
    return SpectrumResult(
        z_map=z,
        log_spectrum=log_spectrum,
        filtered_spectrum=filtered,
        peaks=tuple(chosen),
        candidates=tuple(candidates),
        features=peak_features(chosen, settings.n_peaks, count_peaks(candidates, settings.peak_count, settings.strong_fraction)),
        dominant_period_px=dominant,
        settings=settings,
        dc_radius_bins=dc_bins,
        peak_size_bins=peak_bins,
        floor_mean=floor[0],
        floor_std=floor[1],
        magnitude=magnitude,
        raw_peaks=tuple(order_peaks(raw)),
    )


