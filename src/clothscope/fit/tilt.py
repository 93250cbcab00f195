"""The cloth's tilt against the camera, read from the perspective of its texture.

Shading alone cannot tell a tilted cloth under one light from a level cloth
under a turned light (a Lambertian patch shades by its normal-to-light angle
only), so the geometry stage pins the best-fit plane of its depths. Perspective
can tell them apart: threads farther from the camera look finer (shape from
texture). On a plane ``z = s . x`` seen from distance ``D``, a lattice peak
``k`` has the local image frequency, relative to the centre's,
``1 - (s . x + (s . k^)(x . k^)) / D``: depth scales every direction, and
foreshortening adds as much again along the tilt.

For each of the texture's two strongest non-parallel lattice peaks the image
is band-passed around the peak (an analytic signal), the local frequency is
read from the gradient of its phase, and a plane is fitted to it; its slope
across the image is ``-(I + k^ k^T) s / D``. The two peaks' equations are
solved for ``s`` by weighted least squares (weights from each plane's
standard errors) and the result is shrunk toward level by a Gaussian prior on
the tilt, so a texture without a lattice (pile, a plain colour) reads as
level instead of as noise.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from scipy import ndimage

from clothscope.core.fourier import window_2d
from clothscope.core.imageio import luminance
from clothscope.fit.model import FitCamera

#: lattice peaks searched between these periods (px of a 256 px image; scaled with the image);
#: below about 4 px the phase gradient aliases on the working image's pixel grid
MIN_PERIOD_PX, MAX_PERIOD_PX = 4.0, 25.0
#: half-width of the band around a peak, relative to the peak frequency
BAND = 0.15
#: border (fraction of the image) left out of the plane fit, where the band-pass wraps
BORDER = 1 / 16
#: two peaks are parallel (harmonics of one thread direction) when their angle's sine is below this
PARALLEL_SINE = 0.25


@dataclass(frozen=True)
class TiltEstimate:
    """Slopes ``dz/dx`` and ``dz/dy`` of the cloth's best-fit plane (z toward the camera), with standard errors."""

    slope_x: float = 0.0
    slope_y: float = 0.0
    stderr_x: float = np.inf
    stderr_y: float = np.inf
    periods_px: tuple[float, ...] = ()

    @property
    def degrees(self) -> float:
        return float(np.degrees(np.arctan(np.hypot(self.slope_x, self.slope_y))))

    def shrunk(self, prior_deg: float) -> TiltEstimate:
        """The posterior mean under a zero-mean Gaussian prior of spread ``prior_deg`` per axis."""
        prior = np.tan(np.deg2rad(prior_deg)) ** 2
        gain = [prior / (prior + s**2) if np.isfinite(s) else 0.0 for s in (self.stderr_x, self.stderr_y)]
        return TiltEstimate(self.slope_x * gain[0], self.slope_y * gain[1], self.stderr_x, self.stderr_y, self.periods_px)

    def as_record(self) -> dict[str, Any]:
        finite = {k: (float(v) if np.isfinite(v) else None) for k, v in asdict(self).items() if k != "periods_px"}
        return finite | {"periods_px": [round(p, 3) for p in self.periods_px], "degrees": self.degrees}


def contrast_texture(image: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Luminance over its local mean, less one: the texture with smooth shading divided out; 0 where weight is 0."""
    lum = luminance(image)
    local = ndimage.gaussian_filter(lum, image.shape[0] / 40.0)
    return np.where(weight > 0, lum / np.maximum(local, 1e-4) - 1.0, 0.0)


def frequency_grid(n: int) -> tuple[np.ndarray, np.ndarray]:
    """FFT frequencies (cycles per pixel) along x (columns) and y (rows), broadcastable."""
    return np.fft.fftfreq(n)[None, :], np.fft.fftfreq(n)[:, None]


def lattice_peaks(spectrum: np.ndarray, count: int = 2) -> list[tuple[float, float]]:
    """The ``count`` strongest non-parallel local maxima of an amplitude spectrum, as (fx, fy).

    Only one half-plane is searched (the spectrum of a real image is symmetric)
    and only periods between :data:`MIN_PERIOD_PX` and :data:`MAX_PERIOD_PX`
    (scaled to the image size).
    """
    n = spectrum.shape[0]
    fx, fy = frequency_grid(n)
    radius = np.hypot(fx, fy)
    scale = n / 256.0
    score = np.where((radius > 1 / (MAX_PERIOD_PX * scale)) & (radius < 1 / (MIN_PERIOD_PX * scale)), spectrum, 0.0)
    score[(fy > 0) | ((fy == 0) & (fx < 0))] = 0.0
    score *= score == ndimage.maximum_filter(score, 3, mode="wrap")
    peaks: list[tuple[float, float]] = []
    while len(peaks) < count and score.max() > 0:
        row, col = np.unravel_index(int(np.argmax(score)), score.shape)
        peak = (float(fx[0, col]), float(fy[row, 0]))
        peaks.append(peak)
        angle = np.arctan2(fy, fx) - np.arctan2(peak[1], peak[0])
        score[np.abs(np.sin(angle)) < PARALLEL_SINE] = 0.0
    return peaks


def local_frequency(texture: np.ndarray, peak: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Local frequency along ``peak`` relative to it, and the band's amplitude, at interior pixels.

    The band-pass is a Gaussian of relative width :data:`BAND` around the peak
    on one side only, so its output is complex and its phase advances by the
    local frequency per pixel.
    """
    fx, fy = frequency_grid(texture.shape[0])
    kx, ky = peak
    k2 = kx * kx + ky * ky
    band = np.exp(-((fx - kx) ** 2 + (fy - ky) ** 2) / (2 * BAND**2 * k2))
    signal = np.fft.ifft2(np.fft.fft2(texture) * band)
    gx = np.angle(signal[1:-1, 2:] * np.conj(signal[1:-1, :-2])) / (4 * np.pi)
    gy = np.angle(signal[2:, 1:-1] * np.conj(signal[:-2, 1:-1])) / (4 * np.pi)
    return (gx * kx + gy * ky) / k2, np.abs(signal[1:-1, 1:-1])


def frequency_plane(ratio: np.ndarray, amplitude: np.ndarray, correlation_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Weighted plane ``c0 + c1 sx + c2 sy`` through a local-frequency map over image coordinates in [-1, 1].

    Returns the coefficients and the standard errors of ``c1`` and ``c2``,
    counting one independent sample per ``correlation_px`` squared.
    """
    n = ratio.shape[0] + 2
    s = (np.arange(1, n - 1) + 0.5) / n * 2 - 1
    sx, sy = np.meshgrid(s, s)
    inner = slice(int(n * BORDER), -int(n * BORDER) or None)
    w = amplitude[inner, inner].ravel() ** 2
    design = np.stack([np.ones_like(w), sx[inner, inner].ravel(), sy[inner, inner].ravel()], axis=1)
    r = ratio[inner, inner].ravel()
    total = float(w.sum())
    if not total > 0:
        return np.full(3, np.nan), np.full(2, np.inf)
    normal = design.T @ (design * w[:, None]) / total
    try:
        coef = np.linalg.solve(normal, design.T @ (r * w) / total)
        covariance = np.linalg.inv(normal)
    except np.linalg.LinAlgError:  # the weighted pixels do not span a plane (e.g. one unclipped row)
        return np.full(3, np.nan), np.full(2, np.inf)
    variance = float(np.sum(w * (r - design @ coef) ** 2)) / total
    samples = max(w.size / correlation_px**2, 4.0)
    stderr = np.sqrt(np.diag(covariance)[1:] * variance / samples)
    return coef, stderr


def estimate_tilt(image: np.ndarray, weight: np.ndarray, camera: FitCamera, prior_deg: float) -> TiltEstimate:
    """Tilt of the cloth's best-fit plane against ``camera`` from the perspective of its texture.

    Parameters
    ----------
    image : (H, W, 3) linear RGB working image (square).
    weight : (H, W) pixel weights (0 for clipped pixels).
    camera : the fit camera (its field of view turns slopes across the image into slopes of z).
    prior_deg : spread of the tilt prior per axis; 0 returns a level plane.

    Returns
    -------
    The shrunk estimate; level (zero slopes, infinite errors) when the image
    has no lattice or the numbers are not finite.
    """
    if prior_deg <= 0 or image.shape[0] < 32 or image.shape[0] != image.shape[1]:
        return TiltEstimate()
    texture = contrast_texture(image, weight)
    spectrum = np.abs(np.fft.fft2(texture * window_2d(texture.shape[0], "hann")))
    half_width = np.tan(np.deg2rad(camera.fov_deg) / 2.0)
    normal, right, periods = np.zeros((2, 2)), np.zeros(2), []
    for peak in lattice_peaks(spectrum):
        ratio, amplitude = local_frequency(texture, peak)
        if not np.any(amplitude > 0):
            continue
        coef, stderr = frequency_plane(ratio, amplitude * (weight[1:-1, 1:-1] > 0), 1.0 / (BAND * np.hypot(*peak)))
        if not coef[0] > 0:  # no phase progression: not a lattice
            continue
        # image columns run along +x and image rows along -y
        gradient = np.array([-coef[1], coef[2]]) / (coef[0] * half_width)
        inverse_variance = np.diag(1.0 / np.maximum((stderr / (coef[0] * half_width)) ** 2, 1e-30))
        along = np.array([peak[0], -peak[1]]) / np.hypot(*peak)
        design = np.eye(2) + np.outer(along, along)
        if np.all(np.isfinite(gradient)) and np.all(np.isfinite(inverse_variance)):
            normal += design.T @ inverse_variance @ design
            right += design.T @ inverse_variance @ gradient
            periods.append(1.0 / float(np.hypot(*peak)))
    if not periods or abs(np.linalg.det(normal)) < 1e-30:
        return TiltEstimate()
    slopes = np.linalg.solve(normal, right)
    stderr = np.sqrt(np.diag(np.linalg.inv(normal)))
    return TiltEstimate(float(slopes[0]), float(slopes[1]), float(stderr[0]), float(stderr[1]), tuple(periods)).shrunk(prior_deg)
