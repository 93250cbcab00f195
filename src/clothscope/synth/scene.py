"""Mitsuba scene of the synthetic photo: true micro-geometry, only the effects a class needs.

The cloth is a finely tessellated mesh displaced by the thread height field
along the normals of its smooth folds (no normal mapping), lit by a small
spherical area light and seen by a perspective camera. Open weaves get real
holes over a backdrop; sheer cloth adds diffuse transmission and the only
multi-bounce integrator; pile adds sheen.
"""
from __future__ import annotations

from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np

from clothscope.synth.fabrics import FabricSpec


@dataclass(frozen=True)
class Camera:
    origin: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float]
    fov_deg: float
    resolution: int


@dataclass(frozen=True)
class Light:
    position: tuple[float, float, float]
    radius: float
    intensity: float  # radiant intensity toward the cloth, W/sr (linear RGB units)

    @property
    def radiance(self) -> float:
        return self.intensity / (np.pi * self.radius**2)


def cloth_bsdf(mi: ModuleType, spec: FabricSpec, color: np.ndarray | dict[str, Any], roughness: float, specular: float) -> Any:
    """Principled reflection; the thin-sheet variant with diffuse transmission for sheer cloth only.

    ``color`` is one linear RGB colour or a Mitsuba texture description.
    """
    principled = {
        "type": "principled",
        "base_color": color if isinstance(color, dict) else {"type": "rgb", "value": [float(c) for c in color]},
        "roughness": float(roughness),
        "specular": float(specular),
    }
    if spec.anisotropic:
        principled["anisotropic"] = float(spec.anisotropic)
    if spec.sheen:
        principled.update(sheen=float(spec.sheen), sheen_tint=0.5)
    if not spec.sheer:
        return mi.load_dict(principled)
    # thin sheet: same reflection, plus diffuse transmission; eta from the principled specular
    f0 = 0.08 * float(specular)
    eta = (1 + np.sqrt(f0)) / (1 - np.sqrt(f0))
    thin = {k: v for k, v in principled.items() if k != "specular"}
    thin.update(type="principledthin", diff_trans=0.4, eta=float(eta))
    return mi.load_dict(thin)


def effects_for(spec: FabricSpec, spp: int) -> dict[str, Any]:
    """The rendering effects this class calls for, recorded in its ground truth."""
    return {
        "integrator": "path" if spec.sheer else "direct",
        "max_depth": 3 if spec.sheer else 1,
        "spp": int(spp),
        "micro_geometry": "displaced mesh",
        "holes_over_backdrop": spec.open_weave,
        "diffuse_transmission": spec.sheer,
        "sheen": bool(spec.sheen),
        "anisotropic_specular": bool(spec.anisotropic),
        "area_light_samples_per_pixel": int(spp),
        "spectral": False,
        "polarized": False,
    }


def scene_dict(mi: ModuleType, mesh: Any, camera: Camera, light: Light | None, effects: dict[str, Any], backdrop: np.ndarray | None, seed: int) -> dict[str, Any]:
    """Assemble the Mitsuba scene description (without a light when ``light`` is None: the caller adds its own)."""
    if effects["integrator"] == "path":
        integrator = {"type": "path", "max_depth": effects["max_depth"], "hide_emitters": True}
    else:
        integrator = {"type": "direct", "emitter_samples": 1, "bsdf_samples": 1}
    scene: dict[str, Any] = {
        "type": "scene",
        "integrator": integrator,
        "sensor": {
            "type": "perspective",
            "fov": camera.fov_deg,
            "to_world": mi.ScalarTransform4f().look_at(origin=camera.origin, target=camera.target, up=camera.up),
            "film": {"type": "hdrfilm", "width": camera.resolution, "height": camera.resolution, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": effects["spp"], "seed": seed},
        },
    }
    if light is not None:
        scene["light"] = {
            "type": "sphere",
            "center": list(light.position),
            "radius": light.radius,
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": light.radiance}},
        }
    scene["cloth"] = mesh
    if backdrop is not None:
        scene["backdrop"] = {
            "type": "rectangle",
            "to_world": mi.ScalarTransform4f().translate([0.0, 0.0, -0.25]).scale(4.0),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [float(c) for c in backdrop]}},
        }
    return scene


def render(mi: ModuleType, scene: dict[str, Any], seed: int) -> np.ndarray:
    """Render to a linear float32 (H, W, 3) array."""
    image = mi.render(mi.load_dict(scene), seed=seed)
    return np.array(image, dtype=np.float32)[..., :3]
