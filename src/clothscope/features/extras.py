"""Extra rotation-, scale- and colour-invariant spectrum features (``x_*`` columns), kept apart from the paper's set."""
from __future__ import annotations

import math

import numpy as np

from clothscope.core.fourier import radius_grid
from clothscope.features.paper import SpectrumResult


def _fold_angle(a: float, b: float) -> float:
    """Angle between two undirected directions (degrees), folded to [0, 90]."""
    diff = abs(a - b) % 180.0
    return min(diff, 180.0 - diff)


def spectral_flatness(values: np.ndarray) -> float:
    """Geometric over arithmetic mean of the power ``values`` (1 = white, -> 0 = peaky); 1 if empty or zero."""
    power = np.asarray(values, dtype=np.float64) ** 2
    if power.size == 0 or not power.max() > 0:
        return 1.0
    power = power / power.max()
    geometric = float(np.exp(np.mean(np.log(power + 1e-300))))
    return float(min(1.0, geometric / float(power.mean())))


def extra_features(result: SpectrumResult) -> dict[str, float]:
    """Extra rotation-, scale- and colour-invariant features, kept apart from the paper's set.

    Returns
    -------
    dict of str to float
        ``x_angle_deg``: angle between the two strongest peaks (before
        merging by radius, so the two equal-radius fundamentals of a plain
        weave both count) folded to
        [0, 90] degrees (0 with fewer than two peaks; ~90 for a woven lattice);
        ``x_low_radius_ratio``: lowest over second-lowest peak radius, in
        (0, 1] (0 with fewer than two peaks); ``x_strong_to_low_radius``:
        radius of the strongest peak over the lowest peak radius (~2 when the
        2nd harmonic dominates; 0 without peaks); ``x_flatness``: spectral
        flatness of the DC-removed power in the annulus (1 for white noise);
        ``x_peak_fraction``: share of the annulus magnitude within the chosen
        peaks' filter windows. All values are finite.
    """
    peaks = result.candidates
    raw = result.raw_peaks
    angle = _fold_angle(raw[0].angle_deg, raw[1].angle_deg) if len(raw) >= 2 else 0.0
    radii = sorted(p.radius_bins for p in peaks)
    low_ratio = radii[0] / radii[1] if len(radii) >= 2 and radii[1] > 0 else 0.0
    strong_to_low = peaks[0].radius_bins / radii[0] if peaks and radii[0] > 0 else 0.0
    size = result.magnitude.shape[0]
    dy, dx, radius = radius_grid(size)
    annulus = (radius >= result.dc_radius_bins) & (radius <= size / 2)
    flatness = spectral_flatness(result.magnitude[annulus])
    total = float(result.magnitude[annulus].sum())
    fraction = 0.0
    if total > 0 and result.peaks:
        near = np.zeros_like(annulus)
        half = result.peak_size_bins / 2.0
        for peak in result.peaks:
            for sign in (1.0, -1.0):
                row = size // 2 + sign * (peak.row - size // 2)
                col = size // 2 + sign * (peak.col - size // 2)
                near |= (np.abs(dy + size // 2 - row) <= half) & (np.abs(dx + size // 2 - col) <= half)
        fraction = float(result.magnitude[annulus & near].sum()) / total
    values = {
        "x_angle_deg": angle,
        "x_low_radius_ratio": low_ratio,
        "x_strong_to_low_radius": strong_to_low,
        "x_flatness": flatness,
        "x_peak_fraction": fraction,
    }
    return {key: float(value) if math.isfinite(value) else 0.0 for key, value in values.items()}
