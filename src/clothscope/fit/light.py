"""Light direction from a photo's low-frequency shading and from its threads.

Real photos come with an unknown light. We model it as one point light at a
fixed distance from the cloth centre and estimate its direction by matching
the image's smooth brightness falloff (cosine and inverse-square terms over a
flat Lambertian plane) on a polar x azimuth grid. The overall scale is left
to the base colour (see :mod:`.model` for the exposure convention). The
geometry stage turns that estimate with the cloth's tilt (:func:`tilted`) and
then refines its direction along with the folds and the BSDF
(:func:`apply_light`), where the full BSDF and the fitted folds replace the
grid search's flat Lambertian plane.

A close-up crop of a larger frame shows almost no falloff, so the grid search
then reads vignetting or nothing and puts the light near the lens. The threads
tell the light's side instead (:func:`thread_light`): a convex yarn lit from
one side brightens slowly toward the light and darkens sharply past its crown,
so the shading's gradients have a third moment pointing away from the light.
A light at the lens lights both flanks alike and leaves that moment near zero.
"""
from __future__ import annotations

from types import ModuleType
from typing import Any

import drjit as dr
import numpy as np
from scipy import ndimage

from clothscope.core.imageio import luminance
from clothscope.fit.model import FitCamera, FitLight, calibrated_intensity
from clothscope.prepare.shading import shading

#: the light is kept at least this cosine above the cloth's horizon while it is fitted
MIN_COSINE = 0.1


def plane_points(camera: FitCamera, resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) on z = 0 seen by each pixel centre of a ``resolution``-px image, row 0 at +y."""
    centres = (np.arange(resolution) + 0.5) / resolution * camera.view_width - camera.view_width / 2
    x, y = np.meshgrid(centres, centres[::-1])
    return x, y


def lambert_falloff(light: FitLight, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Irradiance cos(theta) / d^2 on the plane z = 0 (unit intensity)."""
    lx, ly, lz = light.position
    dx, dy = lx - x, ly - y
    d2 = dx**2 + dy**2 + lz**2
    return lz / d2**1.5


def estimate_light(image: np.ndarray, weight: np.ndarray, camera: FitCamera, distance: float = 3.0,
                   polar_step: float = 4.0, azimuth_step: float = 10.0, max_polar: float = 64.0) -> tuple[FitLight, float]:
    """Best point-light direction for the smooth shading of ``image``.

    Parameters
    ----------
    image : (H, W, 3) linear RGB working image.
    weight : (H, W) pixel weights (0 for clipped pixels).

    Returns
    -------
    The light and the relative residual of the best fit (0 = perfect).

    Raises
    ------
    ValueError
        When every pixel it samples is clipped (``prepare`` rejects photos far short of that).
    """
    size = 16
    zoom = size / image.shape[0]
    target = ndimage.zoom(luminance(image) * weight, zoom, order=1)
    mask = ndimage.zoom(weight.astype(float), zoom, order=1) > 0.5
    if not mask.any():
        raise ValueError(f"no unclipped pixel among the 16 x 16 the light is placed by ({int(np.sum(weight > 0))} of "
                         f"{weight.size} pixels unclipped)")
    x, y = plane_points(camera, size)
    best, best_residual = FitLight(0.0, 0.0, distance), np.inf
    norm = float(np.sum(target[mask] ** 2)) + 1e-12
    for polar in np.arange(0.0, max_polar + 1e-9, polar_step):
        for azimuth in (np.arange(0.0, 360.0, azimuth_step) if polar > 0 else [0.0]):
            light = FitLight(float(polar), float(azimuth), distance)
            shade = lambert_falloff(light, x, y)[mask]
            scale = float(shade @ target[mask]) / float(shade @ shade)
            residual = float(np.sum((scale * shade - target[mask]) ** 2)) / norm
            if residual < best_residual:
                best, best_residual = light, residual
    return best, best_residual


#: pixels (working resolution) of the Gaussian derivative that :func:`thread_light` takes
THREAD_GRADIENT_SIGMA = 0.7
#: pixels of the blur whose shading (folds, falloff) :func:`thread_light` removes first, and of the border it leaves out
THREAD_FOLD_SCALE = 16


def thread_light(image: np.ndarray, weight: np.ndarray) -> tuple[float, float]:
    """Azimuth (degrees, image +x = 0, +y up) of the side the threads are lit from, and the strength of that reading.

    The strength is the length of ``-E[g |g|^2]`` for the shading's gradients ``g``
    in units of their RMS (a dimensionless third moment): near 0 under a light at
    the lens or on a photo without relief, larger the more one-sided the lighting.

    Parameters
    ----------
    image : (H, W, 3) linear RGB working image.
    weight : (H, W) pixel weights (0 for clipped pixels, which are left out with their neighbours).
    """
    field = shading(image)
    field = field - ndimage.gaussian_filter(field, THREAD_FOLD_SCALE)
    gy = -ndimage.gaussian_filter(field, THREAD_GRADIENT_SIGMA, order=(1, 0))  # rows run along -y
    gx = ndimage.gaussian_filter(field, THREAD_GRADIENT_SIGMA, order=(0, 1))
    keep = ndimage.binary_erosion(weight > 0, iterations=2)
    m = THREAD_FOLD_SCALE
    keep[:m], keep[-m:], keep[:, :m], keep[:, -m:] = False, False, False, False
    gx, gy = gx[keep], gy[keep]
    rms = float(np.sqrt(np.mean(gx**2 + gy**2))) if gx.size else 0.0
    if rms <= 1e-9:
        return 0.0, 0.0
    gx, gy = gx / rms, gy / rms
    squared = gx**2 + gy**2
    moment = -np.array([np.mean(gx * squared), np.mean(gy * squared)])
    return float(np.degrees(np.arctan2(moment[1], moment[0])) % 360.0), float(np.hypot(*moment))


def light_along(direction: np.ndarray, distance: float, incidence_deg: float) -> FitLight:
    """The :class:`FitLight` at ``distance`` along the unit ``direction``, with the given incidence."""
    polar = float(np.degrees(np.arccos(np.clip(direction[2], -1.0, 1.0))))
    azimuth = float(np.degrees(np.arctan2(direction[1], direction[0])) % 360.0)
    return FitLight(polar, azimuth, distance, incidence_deg)


def tilted(light: FitLight, slope_x: float, slope_y: float) -> FitLight:
    """``light`` turned with the cloth when the cloth tilts to the slopes ``(dz/dx, dz/dy) = (slope_x, slope_y)``.

    The light direction is estimated against a level plane; shading fixes only
    the light's direction relative to the cloth, so a tilted cloth takes its
    light along (the rotation that takes +z to the tilted normal).
    """
    from scipy.spatial.transform import Rotation  # imported here: only the geometry stage tilts the light

    turn, _ = Rotation.align_vectors([cloth_normal(slope_x, slope_y)], [[0.0, 0.0, 1.0]])
    incidence = light.polar_deg if light.incidence_deg is None else light.incidence_deg
    return light_along(turn.apply(light.direction), light.distance, incidence)


#: radians of light-direction change per unit of its latent (keeps Adam's first steps to a few degrees)
LIGHT_STEP = 0.25


def light_frame(light: FitLight) -> np.ndarray:
    """Rows: the light's unit direction from the cloth centre and two unit tangents across it."""
    direction = light.direction
    helper = np.array([0.0, 0.0, 1.0]) if abs(direction[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    first = np.cross(direction, helper)
    first /= np.linalg.norm(first)
    return np.stack([direction, first, np.cross(direction, first)])


def turned_direction(frame: np.ndarray, latent: Any, normalise: Any) -> Any:
    """Unit direction ``frame[0]`` turned across by the two-element ``latent`` (NumPy or Dr.Jit)."""
    d = [float(frame[0, k]) + LIGHT_STEP * (latent[0] * float(frame[1, k]) + latent[1] * float(frame[2, k])) for k in range(3)]
    return normalise(d)


def cloth_normal(slope_x: float, slope_y: float) -> np.ndarray:
    """Unit normal (toward the camera) of the plane ``z = slope_x x + slope_y y``."""
    normal = np.array([-slope_x, -slope_y, 1.0])
    return normal / np.linalg.norm(normal)


def apply_light(mi: ModuleType, params: Any, light: FitLight, latent: Any, normal: np.ndarray) -> None:
    """Write the light turned by ``latent`` into the scene, its intensity following the exposure convention."""
    def normalise(d: list[Any]) -> Any:
        return dr.normalize(mi.Vector3f(*d))

    latent = [dr.gather(mi.Float, latent, i) for i in range(2)]
    direction = turned_direction(light_frame(light), latent, normalise)
    cosine = dr.maximum(dr.dot(direction, mi.Vector3f(*(float(c) for c in normal))), MIN_COSINE)
    params["light.position"] = mi.Point3f(direction * light.distance)
    params["light.intensity.value"] = mi.Color3f(calibrated_intensity(light.distance, cosine))


def light_from_latent(light: FitLight, latent: np.ndarray, normal: np.ndarray) -> FitLight:
    """The :class:`FitLight` that :func:`apply_light` renders for ``latent``."""
    direction = turned_direction(light_frame(light), np.asarray(latent, dtype=np.float64), lambda d: np.array(d) / np.linalg.norm(d))
    incidence = float(np.degrees(np.arccos(max(float(direction @ normal), MIN_COSINE))))
    return light_along(direction, light.distance, incidence)
