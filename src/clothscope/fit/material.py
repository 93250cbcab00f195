"""Stage 2, ``fit_material``: one base colour, one specular value and one roughness.

Each parameter lives in an unbounded latent space (logistic), so it can never
leave its valid range: colour and specular in (0, 1), roughness in
(``min_roughness``, 1). The geometry of stage 1 stays fixed.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import drjit as dr
import numpy as np
from scipy.special import expit

from clothscope.fit.effects import Plan
from clothscope.fit.loop import LoopSettings, logit, optimise, render, sigmoid
from clothscope.fit.model import BSDF_KEYS, FitScene, Material, build_scene
from clothscope.fit.target import Target, image_loss


@dataclass(frozen=True)
class MaterialSettings:
    """Knobs of the material stage (``fit.material`` in the config schema, which holds the defaults)."""

    resolution: int
    spp: int
    sampler: str
    iterations: int
    learning_rate: float
    min_roughness: float


def material_latents(material: Material, min_roughness: float) -> dict[str, np.ndarray]:
    """Unbounded latent variables of a material."""
    rough = (max(material.roughness, min_roughness + 1e-3) - min_roughness) / (1 - min_roughness)
    return {"color": logit(np.array(material.base_color)), "specular": logit(np.array([material.specular])),
            "roughness": logit(np.array([rough]))}


def material_from_latents(latents: dict[str, np.ndarray], min_roughness: float) -> Material:
    """Inverse of :func:`material_latents` on plain arrays (other keys, such as vertex latents, are ignored)."""
    s = {key: expit(np.asarray(latents[key], dtype=np.float64)) for key in ("color", "specular", "roughness")}
    return Material(tuple(float(c) for c in s["color"]), float(s["specular"][0]),
                    float(min_roughness + (1 - min_roughness) * s["roughness"][0]))


def base_color(mi: ModuleType, latent: Any) -> Any:
    """Differentiable RGB base colour in (0, 1) of its 3-element latent."""
    return mi.Color3f(*(sigmoid(dr.gather(mi.Float, latent, i)) for i in range(3)))


def apply_material(mi: ModuleType, params: Any, latents: Any, min_roughness: float, textured: bool = False) -> None:
    """Write differentiable material latents into the scene parameters (``textured``: the caller writes the colour texture)."""
    if not textured:
        params[BSDF_KEYS["base_color"]] = base_color(mi, latents["color"])
    params[BSDF_KEYS["specular"]] = sigmoid(latents["specular"])
    params[BSDF_KEYS["roughness"]] = min_roughness + (1 - min_roughness) * sigmoid(latents["roughness"])


def fit_material(mi: ModuleType, fit: FitScene, target: Target, plan: Plan, settings: MaterialSettings,
                 log: logging.Logger, sample_seed: int) -> tuple[Material, Any]:
    """Fit the BSDF of ``fit`` (geometry fixed) to ``target``; returns the material and the loop result.

    ``sample_seed`` is the config's ``fit.sample_seed`` (which render samples the steps draw).
    """
    scene = build_scene(mi, fit, target.resolution, plan.integrator_dict(), settings.sampler, sample_border=plan.projective)
    params = mi.traverse(scene)

    def loss_fn(opt, render_seed):
        apply_material(mi, params, opt, settings.min_roughness)
        params.update()
        return image_loss(mi, render(mi, scene, params, settings.spp, render_seed), target)

    loop = optimise(mi, material_latents(fit.material, settings.min_roughness), loss_fn,
                    LoopSettings(settings.iterations, settings.learning_rate, sample_seed=sample_seed), log, "material")
    return material_from_latents(loop.best, settings.min_roughness), loop
