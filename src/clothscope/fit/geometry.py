"""Stage 1, ``fit_geometry``: vertex depths of a 64 x 64 plane with Large Steps.

Only depth moves (x and y stay on their grid, so vertices cannot drift in
plane) and the mean depth is pinned to 0 (so depth cannot trade against
brightness through the light's falloff). With ``pin_tilt`` the best-fit plane
of the depths is pinned too: a global tilt of the cloth shades like a turned
light, so a tilt fitted from shading only absorbs noise (on the synthetic set
it made the fold normals worse). The plane is pinned to the tilt read from
the texture's perspective instead (:mod:`.tilt`, shrunk toward level by the
prior ``tilt_prior_deg``; 0 pins it level), and the light, estimated against a
level plane, is turned with it.
The BSDF (colour, specular, roughness) is fitted along with the depths, since
how a fold shades depends on it. Fitted on a box-filtered 64 px target, where
thread detail is averaged away and only the folds remain.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from types import ModuleType
from typing import Any

import drjit as dr
import numpy as np

from clothscope.fit.effects import Evidence, geometry_evidence, plan_stage
from clothscope.fit.light import (
    apply_light,
    cloth_normal,
    estimate_light,
    lambert_falloff,
    light_from_latent,
    plane_points,
    thread_light,
    tilted,
)
from clothscope.fit.loop import LoopSettings, optimise, render
from clothscope.fit.material import apply_material, material_from_latents, material_latents
from clothscope.fit.model import BSDF_KEYS, FitCamera, FitLight, FitScene, Material, build_scene, plane_grid
from clothscope.fit.target import Target, at_resolution, image_loss
from clothscope.fit.tilt import TiltEstimate, estimate_tilt


@dataclass(frozen=True)
class GeometrySettings:
    """Knobs of the geometry stage (``fit.geometry`` in the config schema, which holds the defaults)."""

    resolution: int
    spp: int
    sampler: str
    iterations: int
    learning_rate: float
    vertices_per_side: int
    large_steps_lambda: float
    fov_deg: float
    margin: float
    initial_roughness: float
    initial_specular: float
    min_roughness: float
    pin_tilt: bool
    tilt_prior_deg: float
    fit_light: bool
    light_start: str  # "falloff": the grid search alone; "threads": the threads' side when they show one
    thread_light_strength: float  # the least strength of thread_light that overrides the falloff's azimuth
    thread_light_polar_deg: float  # the least polar angle of a light the threads place


def starting_light(photo: Target, camera: FitCamera, settings: GeometrySettings) -> tuple[FitLight, dict[str, Any]]:
    """The light the stage starts from (level cloth) and the record of how it was found.

    The falloff's grid search (:func:`estimate_light`) gives it; with ``light_start: threads``
    and threads lit from one side (:func:`thread_light` at least ``thread_light_strength``), the
    threads give its azimuth and its polar angle is at least ``thread_light_polar_deg``, and the
    stage keeps that light instead of refining it.
    """
    light, residual = estimate_light(photo.image, photo.weight, camera)
    record: dict[str, Any] = {"falloff": {"polar_deg": light.polar_deg, "azimuth_deg": light.azimuth_deg, "relative_residual": residual},
                              "chosen": "falloff"}
    if settings.light_start == "threads":
        azimuth, strength = thread_light(photo.image, photo.weight)
        record["threads"] = {"azimuth_deg": azimuth, "strength": strength}
        if strength >= settings.thread_light_strength:
            light = FitLight(max(light.polar_deg, settings.thread_light_polar_deg), azimuth, light.distance)
            record["chosen"] = "threads"
    return light, record


def initial_base_color(target: Target, camera: FitCamera, light: FitLight) -> np.ndarray:
    """Lambertian albedo that explains the target's mean brightness under ``light``."""
    x, y = plane_points(camera, target.resolution)
    shade = light.intensity * lambert_falloff(light, x, y) / np.pi
    w = target.weight
    albedo = [(target.image[..., c] * w).sum() / max((shade * w).sum(), 1e-9) for c in range(3)]
    return np.clip(np.array(albedo, dtype=np.float32), 0.01, 0.99)


def fit_geometry(mi: ModuleType, photo: Target, settings: GeometrySettings, full_effects: bool,
                 log: logging.Logger, sample_seed: int) -> tuple[FitScene, dict[str, Any]]:
    """Fit camera-facing depth of the plane mesh to ``photo``; returns the fit and its record.

    ``sample_seed`` is the config's ``fit.sample_seed`` (which render samples the steps draw).
    """
    camera = FitCamera(settings.fov_deg)
    light, light_start = starting_light(photo, camera, settings)
    if light_start["chosen"] == "threads":  # the render would trade its polar angle for relief depth again (docs/design.md)
        settings = replace(settings, fit_light=False)
    tilt = estimate_tilt(photo.image, photo.weight, camera, settings.tilt_prior_deg if settings.pin_tilt else 0.0)
    log.info("tilt from the texture's perspective: %.1f deg (slopes %+.3f, %+.3f)", tilt.degrees, tilt.slope_x, tilt.slope_y)
    light = tilted(light, tilt.slope_x, tilt.slope_y)
    log.info("light: polar %.0f deg, azimuth %.0f deg (from the %s)", light.polar_deg, light.azimuth_deg, light_start["chosen"])
    target = at_resolution(photo, settings.resolution)
    material = Material(tuple(float(c) for c in initial_base_color(target, camera, light)),
                        settings.initial_specular, settings.initial_roughness)
    fit = FitScene(camera, light, tilted_grid(plane_grid(camera, settings.vertices_per_side, settings.margin), tilt),
                   settings.margin, material)
    plan = plan_stage("geometry", Evidence(), full_effects)
    log.info("effects plan: %s (%s)", plan.integrator, "; ".join(plan.reasons))
    normal = cloth_normal(tilt.slope_x, tilt.slope_y)
    loop, steps = run_vertex_loop(mi, fit, target, plan, settings, log, normal, sample_seed)
    update_fit(mi, fit, steps, loop.best, settings, normal)
    if settings.fit_light:
        log.info("light refined: polar %.1f deg, azimuth %.1f deg", fit.light.polar_deg, fit.light.azimuth_deg)
    evidence = geometry_evidence(fit.grid, camera, fit.light)
    plans = [plan.as_record()]
    warnings = list(loop.warnings)
    curve = [row | {"phase": "vertices"} for row in loop.curve]
    refined = plan_stage("geometry", evidence, full_effects)
    if refined.integrator != plan.integrator:
        log.info("fitted geometry calls for %s (%s): refining", refined.integrator, "; ".join(refined.reasons))
        second, steps = run_vertex_loop(mi, fit, target, refined, settings, log, normal,
                                        iterations=max(settings.iterations // 3, 1), sample_seed=sample_seed)
        update_fit(mi, fit, steps, second.best, settings, normal)
        plans.append(refined.as_record())
        warnings += second.warnings
        curve += [row | {"phase": "vertices-refine"} for row in second.curve]
    record = {"light_residual": light_start["falloff"]["relative_residual"], "light_start": light_start,
              "tilt": tilt.as_record(), "effects": plans, "evidence": evidence.__dict__,
              "warnings": warnings, "stopped": loop.stopped, "final_loss": loop.best_loss,
              "settings": settings.__dict__, "sample_seed": sample_seed, "curve": curve}
    return fit, record


def run_vertex_loop(mi: ModuleType, fit: FitScene, target: Target, plan: Any, settings: GeometrySettings,
                    log: logging.Logger, normal: np.ndarray, sample_seed: int, iterations: int | None = None) -> tuple[Any, Any]:
    """Large Steps descent on the depth of every vertex, plus the BSDF and (``fit_light``) the light direction.

    ``normal`` is the cloth's pinned mean normal, against which the light's
    exposure convention is kept.
    """
    scene = build_scene(mi, fit, target.resolution, plan.integrator_dict(), settings.sampler, sample_border=plan.projective)
    params = mi.traverse(scene)
    steps = mi.ad.LargeSteps(params[BSDF_KEYS["vertices"]], params["cloth.faces"], settings.large_steps_lambda)
    start = mi.Float(fit.grid.reshape(-1).astype(np.float32))
    u0 = np.array(steps.to_differential(start), dtype=np.float32)
    xy = dr.unravel(mi.Point3f, start)

    slopes = tilt_slopes(fit.grid, settings.pin_tilt)
    plane = mi.Float(pinned_plane(fit.grid, settings.pin_tilt).ravel().astype(np.float32))

    def loss_fn(opt, render_seed):
        v = dr.unravel(mi.Point3f, steps.from_differential(opt["u"]))
        z = pinned_depth(v.z, xy.x, xy.y, slopes, dr.sum) + plane
        params[BSDF_KEYS["vertices"]] = dr.ravel(mi.Point3f(xy.x, xy.y, z))
        apply_material(mi, params, opt, settings.min_roughness)
        if settings.fit_light:
            apply_light(mi, params, fit.light, opt["light"], normal)
        params.update()
        return image_loss(mi, render(mi, scene, params, settings.spp, render_seed), target)

    initial = {"u": u0} | material_latents(fit.material, settings.min_roughness)
    if settings.fit_light:
        initial["light"] = np.zeros(2, dtype=np.float32)
    loop_settings = LoopSettings(iterations if iterations is not None else settings.iterations, settings.learning_rate,
                                 sample_seed=sample_seed)
    return optimise(mi, initial, loss_fn, loop_settings, log, "geometry"), steps


def update_fit(mi: ModuleType, fit: FitScene, steps: Any, best: dict[str, np.ndarray], settings: GeometrySettings,
               normal: np.ndarray) -> None:
    """Write a vertex loop's best latents into ``fit``: depths, BSDF and light."""
    fit.grid = grid_from(mi, steps, best["u"], fit.grid, settings.pin_tilt)
    fit.material = material_from_latents(best, settings.min_roughness)
    if "light" in best:
        fit.light = light_from_latent(fit.light, best["light"], normal)


def tilt_slopes(grid: np.ndarray, pin_tilt: bool) -> tuple[float, float]:
    """``(1 / sum(x**2), 1 / sum(y**2))`` over the grid's centred x and y; zeros when the tilt is free."""
    x, y = grid[..., 0].ravel(), grid[..., 1].ravel()
    return (1.0 / float(x @ x), 1.0 / float(y @ y)) if pin_tilt else (0.0, 0.0)


def pinned_depth(z: Any, x: Any, y: Any, slopes: tuple[float, float], total: Any) -> Any:
    """Depths ``z`` less their mean and, where ``slopes`` is nonzero, their best-fit plane.

    ``x`` and ``y`` are the centred grid coordinates, ``slopes`` comes from
    :func:`tilt_slopes` (zeros keep the tilt) and ``total`` sums an
    array (``np.sum`` or ``dr.sum``), so NumPy and Dr.Jit arrays share this code.
    """
    z = z - total(z) / len(x)
    return z - (total(z * x) * slopes[0]) * x - (total(z * y) * slopes[1]) * y


def tilted_grid(grid: np.ndarray, tilt: TiltEstimate) -> np.ndarray:
    """``grid`` with depths on the plane of ``tilt`` through its centre."""
    tilted = grid.copy()
    tilted[..., 2] = tilt.slope_x * grid[..., 0] + tilt.slope_y * grid[..., 1]
    return tilted


def pinned_plane(grid: np.ndarray, pin_tilt: bool) -> np.ndarray:
    """The best-fit plane of ``grid``'s depths where the tilt is pinned (zeros where it is free)."""
    z = grid[..., 2].ravel()
    if not pin_tilt:
        return np.zeros_like(z)
    return z - pinned_depth(z, grid[..., 0].ravel(), grid[..., 1].ravel(), tilt_slopes(grid, True), np.sum) - z.mean()


def grid_from(mi: ModuleType, steps: Any, u: np.ndarray, base: np.ndarray, pin_tilt: bool) -> np.ndarray:
    """(n, n, 3) grid of the differential coordinates ``u``: x, y of ``base``, depth pinned like the fit's.

    The pinned plane is ``base``'s (the tilt the fit started from).
    """
    v = np.array(steps.from_differential(mi.Float(u)), dtype=np.float64).reshape(base.shape)
    grid = base.copy()
    grid[..., 2] = (pinned_depth(v[..., 2].ravel(), base[..., 0].ravel(), base[..., 1].ravel(), tilt_slopes(base, pin_tilt),
                                 np.sum) + pinned_plane(base, pin_tilt)).reshape(base.shape[:2])
    return grid
