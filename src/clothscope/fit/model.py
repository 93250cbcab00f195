"""The scene every fit stage renders: a camera, one light and a plane mesh.

Camera model: a pinhole camera at distance ``CAMERA_DISTANCE`` looking straight
down at the cloth with a fixed field of view (a close-up photo). The cloth is a
64 x 64 vertex plane spanning the view at z = 0 plus a margin, so its outline
is never in view. Light model: one light whose direction is estimated from the
photo's low-frequency shading (:mod:`.light`) and whose brightness follows the
calibration convention "a white Lambertian patch at the centre reads 0.85";
base colours are reported relative to that exposure. The light is a point
light, or (when the material stage finds it re-renders the photo better) a
distant soft light: a uniform disc of ``spread_deg`` angular radius in an
environment map (:func:`soft_light_map`), like a window or a softbox. With a
point light and one opaque sheet, the position of a sample inside its pixel
is a one-bounce render's only random dimension, so a sampler that stratifies it
(``multijitter``) leaves far less noise per sample than independent sampling
(``workflow/benchmarks/sampler_noise.py``); each stage names its sampler in
its settings.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from types import ModuleType
from typing import Any

import numpy as np

from clothscope.core.mesh import cloth_mesh
from clothscope.fit.integrator import NAME as UNSHADOWED
from clothscope.fit.integrator import register as register_unshadowed

CAMERA_DISTANCE = 3.0
WHITE_PATCH_READING = 0.85
#: Mitsuba sampler of the previews and of the exported ``scene.xml`` (the stages take theirs from their settings)
PREVIEW_SAMPLER = "multijitter"
#: principled-BSDF keys of the cloth inside the ``normalmap`` wrapper
BSDF_KEYS = {
    "base_color": "cloth.bsdf.nested_bsdf.base_color.value",
    "specular": "cloth.bsdf.nested_bsdf.specular",
    "roughness": "cloth.bsdf.nested_bsdf.roughness.value",
    "normalmap": "cloth.bsdf.normalmap.data",
    "albedo": "cloth.bsdf.nested_bsdf.base_color.data",
    "vertices": "cloth.vertex_positions",
}


@dataclass(frozen=True)
class FitCamera:
    """Pinhole camera on the +z axis looking at the origin, +y up in the image."""

    fov_deg: float = 25.0
    distance: float = CAMERA_DISTANCE

    @property
    def view_width(self) -> float:
        """Width of the view at z = 0, world units."""
        return 2.0 * self.distance * np.tan(np.deg2rad(self.fov_deg) / 2.0)


def calibrated_intensity(distance: float, cosine: Any) -> Any:
    """Radiant intensity at which a white Lambertian patch at the cloth centre reads ``WHITE_PATCH_READING``.

    ``cosine`` is the light's incidence cosine there (a float, a NumPy or a Dr.Jit array).
    """
    return WHITE_PATCH_READING * np.pi * distance**2 / cosine


#: side of the soft light's environment map (latitude-longitude, twice as wide): 1.4 degrees per pixel
SOFT_LIGHT_MAP_HEIGHT = 128


@dataclass(frozen=True)
class FitLight:
    """The fit's light, given by its direction from the cloth centre and distance.

    ``incidence_deg`` is its angle from the cloth's mean normal, which sets the
    exposure convention; None means the cloth is level and it equals the polar angle.
    ``spread_deg`` 0 makes it a point light at ``position``; above 0, a distant
    soft light: a uniform disc of that angular radius around the same direction.
    """

    polar_deg: float
    azimuth_deg: float
    distance: float = 3.0
    incidence_deg: float | None = None
    spread_deg: float = 0.0

    @property
    def direction(self) -> np.ndarray:
        """Unit vector from the cloth centre toward the light."""
        return np.asarray(self.position) / self.distance

    @property
    def position(self) -> tuple[float, float, float]:
        polar, azimuth = np.deg2rad(self.polar_deg), np.deg2rad(self.azimuth_deg)
        return (
            float(self.distance * np.sin(polar) * np.cos(azimuth)),
            float(self.distance * np.sin(polar) * np.sin(azimuth)),
            float(self.distance * np.cos(polar)),
        )

    @property
    def incidence_cosine(self) -> float:
        """Cosine of the light's angle from the cloth's mean normal."""
        return float(np.cos(np.deg2rad(self.polar_deg if self.incidence_deg is None else self.incidence_deg)))

    @property
    def intensity(self) -> float:
        """Radiant intensity of the point light under the white-patch calibration convention."""
        return float(calibrated_intensity(self.distance, self.incidence_cosine))


def envmap_directions(height: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions (H, 2H, 3) of a latitude-longitude map's pixel centres in Mitsuba's ``envmap`` convention, and their solid angles (H, 2H).

    Mitsuba looks a direction ``d`` up at ``u = atan2(d.x, -d.z) / 2 pi`` and ``v = acos(d.y) / pi``.
    """
    v = (np.arange(height) + 0.5) / height * np.pi
    u = (np.arange(2 * height) + 0.5) / (2 * height) * 2 * np.pi
    theta, phi = np.meshgrid(v, u, indexing="ij")
    directions = np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], axis=-1)
    solid_angle = np.sin(theta) * (np.pi / height) * (np.pi / height)
    return directions, solid_angle


def soft_light_map(light: FitLight, height: int = SOFT_LIGHT_MAP_HEIGHT) -> np.ndarray:
    """(H, 2H, 3) radiance of ``light``'s soft disc, scaled so a white Lambertian patch at the centre reads ``WHITE_PATCH_READING``.

    The disc's edge is antialiased over one pixel. A disc above the cloth's horizon
    gives the patch ``cos(incidence)`` times the irradiance it gives a patch facing
    it, which the map's own sum sets (so the calibration holds at any resolution).
    """
    if not 0.0 < light.spread_deg < 90.0:
        raise ValueError(f"a soft light needs a spread between 0 and 90 degrees, got {light.spread_deg}")
    directions, solid_angle = envmap_directions(height)
    cosine = directions @ light.direction
    angle = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    coverage = np.clip((light.spread_deg - angle) / (180.0 / height) + 0.5, 0.0, 1.0)
    facing_irradiance = float(np.sum(coverage * np.maximum(cosine, 0.0) * solid_angle))
    radiance = coverage * WHITE_PATCH_READING * np.pi / (facing_irradiance * light.incidence_cosine)
    return np.repeat(radiance[..., None], 3, axis=2).astype(np.float32)


def light_dict(mi: ModuleType, light: FitLight) -> dict[str, Any]:
    """The Mitsuba emitter of ``light``: a point light, or an environment map holding its soft disc."""
    if light.spread_deg > 0:
        return {"type": "envmap", "bitmap": mi.Bitmap(soft_light_map(light))}
    return {"type": "point", "position": list(light.position), "intensity": {"type": "rgb", "value": light.intensity}}


@dataclass
class Material:
    """The one BSDF of the cloth (principled, linear RGB)."""

    base_color: tuple[float, float, float] = (0.5, 0.5, 0.5)
    specular: float = 0.5
    roughness: float = 0.6

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class FitScene:
    """Everything needed to rebuild the fit scene; what the stages pass on."""

    camera: FitCamera
    light: FitLight
    grid: np.ndarray  # (n, n, 3) vertex positions
    margin: float
    material: Material = field(default_factory=Material)

    def to_record(self) -> dict[str, Any]:
        return {
            "camera": asdict(self.camera) | {"view_width": self.camera.view_width},
            "light": asdict(self.light) | {"position": list(self.light.position), "intensity": self.light.intensity},
            "margin": self.margin,
            "material": self.material.as_dict(),
            "mesh_vertices_per_side": int(self.grid.shape[0]),
        }


def plane_grid(camera: FitCamera, n: int, margin: float) -> np.ndarray:
    """(n, n, 3) flat grid covering the view plus ``margin`` (fraction) on each side, rows along +y."""
    half = camera.view_width / 2.0 * (1.0 + margin)
    coords = np.linspace(-half, half, n)
    x, y = np.meshgrid(coords, coords)
    return np.stack([x, y, np.zeros_like(x)], axis=-1)


def texel_centres(texture: int, margin: float) -> np.ndarray:
    """(texture,) centres of a texture's texels along one axis, in fractions of the view (the plane overhangs it by ``margin``)."""
    return ((np.arange(texture) + 0.5) / texture - 0.5) * (1.0 + margin) + 0.5


def grid_texcoords(n: int) -> np.ndarray:
    """(n, n, 2) texture coordinates: u along +x, v along -y, so texture row 0 lies at +y like an image."""
    t = np.linspace(0.0, 1.0, n)
    u, v = np.meshgrid(t, t[::-1])
    return np.stack([u, v], axis=-1)


def flat_normal_texture(size: int) -> np.ndarray:
    """Encoded (0.5 n + 0.5) flat normal map of ``size`` x ``size`` texels."""
    texture = np.full((size, size, 3), 0.5, dtype=np.float32)
    texture[..., 2] = 1.0
    return texture


def shaded_texture(material: Material, shade: np.ndarray, layout: np.ndarray | None = None) -> np.ndarray:
    """(T, T, 3) linear base-colour texture: the material colour times a (T, T) shade (and a (T, T, 3) dye layout)."""
    texture = np.asarray(shade, dtype=np.float32)[..., None] * np.asarray(material.base_color, dtype=np.float32)
    return (texture if layout is None else texture * np.asarray(layout, dtype=np.float32)).astype(np.float32)


def cloth_bsdf_dict(mi: ModuleType, material: Material, normal_texture: np.ndarray,
                    albedo_texture: np.ndarray | None = None, normal_accel: bool = True) -> dict[str, Any]:
    """Principled BSDF wrapped in a normal map (raw bilinear texture); ``albedo_texture``: a (T, T, 3) base-colour texture.

    ``normal_accel=False`` keeps the normal map out of CUDA's hardware texture (Mitsuba's bitmap ``accel``).
    """
    color: dict[str, Any] = {"type": "rgb", "value": [float(c) for c in material.base_color]}
    if albedo_texture is not None:
        color = {"type": "bitmap", "raw": True, "filter_type": "bilinear", "wrap_mode": "clamp",
                 "data": mi.TensorXf(np.ascontiguousarray(albedo_texture, dtype=np.float32))}
    return {
        "type": "normalmap",
        "normalmap": {"type": "bitmap", "raw": True, "filter_type": "bilinear", "wrap_mode": "clamp",
                      "accel": normal_accel, "data": mi.TensorXf(np.ascontiguousarray(normal_texture, dtype=np.float32))},
        "bsdf": {
            "type": "principled",
            "base_color": color,
            "specular": float(material.specular),
            "roughness": float(material.roughness),
        },
    }


def build_scene(mi: ModuleType, fit: FitScene, resolution: int, integrator: dict[str, Any], sampler: str,
                normal_texture: np.ndarray | None = None, sample_border: bool = False,
                albedo_texture: np.ndarray | None = None, normal_accel: bool = True) -> Any:
    """Load the Mitsuba scene of a fit at ``resolution`` px with the given integrator and sampler (and a base-colour texture;
    ``normal_accel``: :func:`cloth_bsdf_dict`)."""
    if integrator["type"] == UNSHADOWED:
        register_unshadowed(mi)
    texture = flat_normal_texture(8) if normal_texture is None else normal_texture
    bsdf = mi.load_dict(cloth_bsdf_dict(mi, fit.material, texture, albedo_texture, normal_accel))
    n = fit.grid.shape[0]
    mesh = cloth_mesh(mi, fit.grid, grid_texcoords(n), np.ones((n, n), dtype=bool), bsdf)
    return mi.load_dict({
        "type": "scene",
        "integrator": integrator,
        "sensor": {
            "type": "perspective",
            "fov": fit.camera.fov_deg,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, fit.camera.distance], target=[0, 0, 0], up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": resolution, "height": resolution, "pixel_format": "rgb",
                     "rfilter": {"type": "box"}, "sample_border": sample_border},
            "sampler": {"type": sampler, "sample_count": 4},
        },
        "light": light_dict(mi, fit.light),
        "cloth": mesh,
    })

