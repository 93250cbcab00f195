"""Centred 2-D Fourier spectra of square maps: windows, frequency grids and the half-plane mask, shared by the stages."""
from __future__ import annotations

import numpy as np

#: Windows :class:`SpectrumSettings` accepts.
WINDOWS = ("hann", "none")


def window_2d(size: int, kind: str) -> np.ndarray:
    """Separable (size, size) window: ``"hann"`` or ``"none"`` (all ones)."""
    if kind == "none":
        return np.ones((size, size))
    if kind == "hann":
        w = np.hanning(size)
        return np.outer(w, w)
    raise ValueError(f"unknown window {kind!r}; expected one of {', '.join(WINDOWS)}")


def centred_spectrum(z: np.ndarray, window: str) -> np.ndarray:
    """Complex FFT of the mean-free, windowed map ``z``, shifted so DC is at ``(N // 2, N // 2)``."""
    return np.fft.fftshift(np.fft.fft2((z - z.mean()) * window_2d(z.shape[0], window)))


def radius_grid(size: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Row offset, column offset and radius (bins) of each bin of a centred spectrum."""
    offsets = np.arange(size) - size // 2
    dy, dx = np.meshgrid(offsets, offsets, indexing="ij")
    return dy, dx, np.hypot(dy, dx)


def upper_half_plane(dy: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """Mask of one half of the point-symmetric spectrum: ``dy < 0``, or ``dy == 0`` and ``dx > 0``.

    ``dy < 0`` is "up" in the image (row 0 at the top), so kept peaks plot above DC.
    """
    return (dy < 0) | ((dy == 0) & (dx > 0))
