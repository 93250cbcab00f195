"""Light direction from a photo's low-frequency shading.

Real photos come with an unknown light. We model it as one point light at a
fixed distance from the cloth centre and estimate its direction by matching
the image's smooth brightness falloff (cosine and inverse-square terms over a
flat Lambertian plane) on a polar x azimuth grid. The overall scale is left
to the base colour (see :mod:`.model` for the exposure convention).
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from .model import FitCamera, PointLight


def luminance(rgb: np.ndarray) -> np.ndarray:
    """Rec. 709 luminance of a linear (H, W, 3) image."""
    return rgb @ np.array([0.2126, 0.7152, 0.0722])


def plane_points(camera: FitCamera, resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) on z = 0 seen by each pixel centre of a ``resolution``-px image, row 0 at +y."""
    centres = (np.arange(resolution) + 0.5) / resolution * camera.view_width - camera.view_width / 2
    x, y = np.meshgrid(centres, centres[::-1])
    return x, y


def lambert_falloff(light: PointLight, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Irradiance cos(theta) / d^2 on the plane z = 0 (unit intensity)."""
    lx, ly, lz = light.position
    dx, dy = lx - x, ly - y
    d2 = dx**2 + dy**2 + lz**2
    return lz / d2**1.5


def estimate_light(image: np.ndarray, weight: np.ndarray, camera: FitCamera, distance: float = 3.0,
                   polar_step: float = 4.0, azimuth_step: float = 10.0, max_polar: float = 64.0) -> tuple[PointLight, float]:
    """Best point-light direction for the smooth shading of ``image``.

    Parameters
    ----------
    image : (H, W, 3) linear RGB working image.
    weight : (H, W) pixel weights (0 for clipped pixels).

    Returns
    -------
    The light and the relative residual of the best fit (0 = perfect).
    """
    size = 16
    zoom = size / image.shape[0]
    target = ndimage.zoom(luminance(image) * weight, zoom, order=1)
    mask = ndimage.zoom(weight.astype(float), zoom, order=1) > 0.5
    x, y = plane_points(camera, size)
    best, best_residual = PointLight(0.0, 0.0, distance), np.inf
    norm = float(np.sum(target[mask] ** 2)) + 1e-12
    for polar in np.arange(0.0, max_polar + 1e-9, polar_step):
        for azimuth in (np.arange(0.0, 360.0, azimuth_step) if polar > 0 else [0.0]):
            light = PointLight(float(polar), float(azimuth), distance)
            shade = lambert_falloff(light, x, y)[mask]
            scale = float(shade @ target[mask]) / float(shade @ shade)
            residual = float(np.sum((scale * shade - target[mask]) ** 2)) / norm
            if residual < best_residual:
                best, best_residual = light, residual
    return best, best_residual
