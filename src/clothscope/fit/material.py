"""Stage 2, ``fit_material``: one base colour, one specular value and one roughness, and the kind of light.

Each parameter lives in an unbounded latent space (logistic), so it can never
leave its valid range: colour and specular in (0, 1), roughness in
(``min_roughness``, 1). The geometry of stage 1 stays fixed.

The light: a window or a softbox widens a highlight as a rougher BSDF would
and evens out the falloff across the frame, so one point light misreads both.
With ``soft_light_deg`` above 0 the stage fits the BSDF twice, under the
geometry stage's point light and under a soft light of that angular radius
in the same direction, re-renders both with many samples, and keeps the soft
light only when its loss is at least ``soft_light_min_gain`` (a fraction)
below the point light's. The choice and both losses go into ``state.json``.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from types import ModuleType
from typing import Any

import drjit as dr
import numpy as np
from scipy.special import expit

from clothscope.fit.effects import Plan
from clothscope.fit.loop import LoopSettings, logit, optimise, render, sigmoid
from clothscope.fit.model import BSDF_KEYS, FitLight, FitScene, Material, build_scene
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
    soft_light_deg: float  # angular radius of the soft light tried beside the point light; 0: point light only
    soft_light_min_gain: float  # relative loss drop the soft light must bring to be kept


#: samples per pixel of the renders that compare the lights (the stage's own renders are noisier)
CHOICE_SPP = 32


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


def rerender_loss(mi: ModuleType, fit: FitScene, target: Target, plan: Plan, settings: MaterialSettings) -> float:
    """Loss of ``fit`` against ``target`` from one render with :data:`CHOICE_SPP` samples per pixel (fixed seed)."""
    scene = build_scene(mi, fit, target.resolution, plan.integrator_dict(), settings.sampler)
    return float(image_loss(mi, mi.render(scene, spp=CHOICE_SPP, seed=1), target).array[0])


def fit_material_and_light(mi: ModuleType, fit: FitScene, target: Target, plan: Plan, settings: MaterialSettings,
                           log: logging.Logger, sample_seed: int) -> tuple[FitLight, Material, Any, dict[str, Any]]:
    """The light (point, or soft when it re-renders ``target`` better), the material fitted under it, its loop and the choice's record."""
    material, loop = fit_material(mi, fit, target, plan, settings, log, sample_seed)
    if settings.soft_light_deg <= 0:
        return fit.light, material, loop, {"chosen": "point", "reason": "no soft light tried (fit.material.soft_light_deg 0)"}
    soft = FitScene(fit.camera, replace(fit.light, spread_deg=settings.soft_light_deg), fit.grid, fit.margin, fit.material)
    soft_material, soft_loop = fit_material(mi, soft, target, plan, settings, log, sample_seed)
    point_loss = rerender_loss(mi, replace(fit, material=material), target, plan, settings)
    soft_loss = rerender_loss(mi, replace(soft, material=soft_material), target, plan, settings)
    keep_soft = soft_loss < (1.0 - settings.soft_light_min_gain) * point_loss
    record = {"chosen": "soft" if keep_soft else "point", "point_loss": point_loss, "soft_loss": soft_loss,
              "spread_deg": settings.soft_light_deg,
              "reason": f"a soft light of {settings.soft_light_deg:g} deg re-renders the photo with "
                        f"{1.0 - soft_loss / max(point_loss, 1e-12):.1%} less loss than the point light "
                        f"({'at least' if keep_soft else 'under'} {settings.soft_light_min_gain:.0%})"}
    log.info("light: %s", record["reason"])
    return (soft.light, soft_material, soft_loop, record) if keep_soft else (fit.light, material, loop, record)
