"""The thread period of a normal map: the peak of the relief spectrum, recovered from the in-plane normals, with the most power times frequency."""
from __future__ import annotations

import math

import numpy as np

from clothscope.core.fourier import centred_spectrum, radius_grid, upper_half_plane
from clothscope.features.paper import FLAT_TOLERANCE, SpectrumSettings, refine_peak, z_component


def thread_period(normal: np.ndarray, settings: SpectrumSettings, weighted: bool = True) -> float | None:
    """Thread period (texels) of a normal map: the relief spectrum's peak with the most power times frequency.

    The z component is about ``1 - |grad h|**2 / 2`` of the relief ``h``: it squares
    the slopes, so its strongest peak is often a harmonic (twice, or sqrt(2) times,
    the thread frequency; open weaves show no peak at the thread frequency at all).
    The in-plane components ``n_x`` and ``n_y`` are linear in the slopes,
    ``N = -i k H``, but the slopes weight each frequency by ``|k|``, which lifts
    harmonics and the plain weave's diagonal (sqrt(2) times the thread
    frequency). So the relief's spectrum is recovered from them,
    ``|H| = |k . N| / |k|**2``. Its power is weighted by ``|k|`` before the
    peak is taken, as ``prepare`` weighs its native-resolution peaks
    (``prepare.period_peak: weighted``): dividing by ``|k|**2`` lifts slow
    relief, such as a colour repeat or shading the fit explained with tilt,
    above the threads; with the weight a harmonic still needs over half the
    threads' power to win (``weighted=False``: the strongest peak). Bins inside the DC disc
    (``settings.dc_radius_bins``) are ignored; the peak is refined to sub-bin
    precision (:func:`refine_peak`).

    Parameters
    ----------
    normal : numpy.ndarray
        (N, N, 3) tangent-space unit normals, N >= 16.
    settings : SpectrumSettings
        Supplies the window and the DC radius.
    weighted : bool
        Weight the power by frequency (True) or take the strongest peak.

    Returns
    -------
    float or None
        The period in texels; None for a flat map.

    Raises
    ------
    ValueError
        If the map is not (N, N, 3), is too small, or holds NaN or infinite values.
    """
    array = np.asarray(normal)
    if array.ndim != 3 or array.shape[-1] != 3:
        raise ValueError(f"normal map must have shape (H, W, 3), got {array.shape}")
    n_x, n_y = (z_component(array[..., c]) for c in (0, 1))
    if np.ptp(n_x) < FLAT_TOLERANCE and np.ptp(n_y) < FLAT_TOLERANCE:
        return None
    size = n_x.shape[0]
    dy, dx, radius = radius_grid(size)
    spectra = [centred_spectrum(c, settings.window) for c in (n_x, n_y)]
    relief = np.abs(dx * spectra[0] - dy * spectra[1]) / np.maximum(radius, 1e-9) ** 2  # image rows run along -y
    relief[radius < settings.dc_radius_bins(size)] = 0.0
    searched = np.where(upper_half_plane(dy, dx), relief**2 * (radius if weighted else 1.0), 0.0)
    if not searched.max() > 0.0:
        return None
    row, col = np.unravel_index(int(np.argmax(searched)), searched.shape)
    peak_row, peak_col = refine_peak(relief, int(row), int(col), 1)
    peak_radius = math.hypot(peak_row - size // 2, peak_col - size // 2)
    return size / peak_radius if peak_radius > 0 else None
