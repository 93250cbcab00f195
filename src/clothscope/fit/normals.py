"""Stage 3, ``fit_normals``: a normal map of thread-level detail, then a joint BSDF refinement.

The optimised variable is a height map ``h`` (in texel widths). Normals are
``normalize(-dh/dx, -dh/dy, 1)`` from central differences, so a normal can
never be zero, in the surface plane or flipped. Phase 1 fits the height map
alone with a plateau stopping rule (the map drifts into noise if left
running); phase 2 refines height map and BSDF jointly, which is what makes
roughness recoverable (it cannot be fitted while the normal map is flat). The
joint phase has no plateau rule and returns its last iterate (see
:mod:`.loop` for why the lowest noisy loss would bias roughness upward).

The image the loss compares with the photo takes more samples per pixel
(``spp``) than the gradient pass (``spp_grad``). The gradient is the residual
times the image's derivative, and at thread scale the residual is mostly the
forward render's own noise; Adam scales its steps down by that noise, so the
roughness drifts to its optimum too slowly. Extra forward samples cost about
half what extra gradient samples do, and on the synthetic set only they
helped (docs/design.md, "Roughness: the joint phase and its samples").

With ``albedo_weight > 0`` the base colour becomes a texture: the material
colour times a per-texel *shade* ``s`` in (0, 1 / s0) (a logistic latent,
1 at the start), fitted with the height map. The prior ``albedo_weight *
mean|s - 1|`` lets the shade take only what the relief cannot explain under
the one light: holes showing a backdrop, occluded crevices, dyed yarns. It
is written as ``shade.exr`` and the colour texture as ``albedo.exr``.

With ``smoothness > 0`` the loss adds ``smoothness * mean(lap(h)^2)``, the
squared 4-neighbour Laplacian of the height map in texel widths: woven and
knitted relief is smooth at the texel scale, so brightness that changes from
one pixel to the next (sensor and JPEG noise, fibres, dark holes under a light
near the camera) is not explained by a tilt that flips from texel to texel.
When the material stage fitted the light within ``near_camera_deg`` of the
camera (a flash, a ring or coaxial light), the weight is at least
``near_camera_smoothness`` (:func:`relief_prior`; 0 by default): the shading is
then ``1 - |grad h|**2 / 2`` to second order, so the photo barely constrains
the slopes and nothing else keeps the height map from texel-scale noise.

With ``large_steps_lambda > 0`` the optimiser's variable is not the height
map but its differential coordinates ``u = (I + lambda L) h`` on the texel
grid (:mod:`.large_steps`), stepped by Uniform Adam, as the geometry stage's
vertices are (Nicolet et al. 2021). Per-texel Adam divides each
texel's step by its own gradient's size, so a texel the photo hardly
constrains (a slope across the light, detail near two texels per cycle) takes
full-size steps on noise; here one step size serves the whole map and the
gradient is diffused over neighbours, so the relief grows from its coarse
scales to its fine ones. The minimum is the same; the path, and so what a
finite number of iterations returns, is not.

With ``initial_relief = "shading"`` the height map starts from the photo's
shading instead of flat (:func:`initial_height`): bright high, dark low, the
dye layout divided out, so what the photo does not constrain starts as the
photo's own pattern instead of as zero.

With ``cavity > 0`` the base colour is also multiplied by a *cavity* factor
of the height map, ``2 sigmoid(-cavity * d)``, where ``d`` is how far a texel
lies below the mean height of a ring :data:`CAVITY_RADIUS` texels around it:
gaps between yarns are darker than crowns because they see less of the light
(occlusion, which a normal map cannot render), so dark is deep enters the
render at first order in the height, under any light, instead of only through
the tilt. The factor is returned in the shade (``shade.exr``, ``albedo.exr``).

With ``repeat_weight > 0`` the loss adds that weight times the mean squared
difference between the height map and itself one repeat of the photo away
(:mod:`.repeat`): where the photo repeats, the relief is asked to repeat too.

With the ``dye_layout`` colour model (:mod:`.colour`) the base colour is also
a texture: the fitted colour times the photo's fixed dye layout (times the
shade, when there is one), written as ``albedo.exr`` too.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from types import ModuleType
from typing import Any

import drjit as dr
import numpy as np
from scipy import ndimage
from scipy.special import expit

from clothscope.fit.colour import ColourModel
from clothscope.fit.effects import UNSHADOWED, Plan
from clothscope.fit.large_steps import HeightSteps
from clothscope.fit.loop import LoopSettings, optimise, render, sigmoid
from clothscope.fit.material import apply_material, material_from_latents, material_latents
from clothscope.fit.model import (
    BSDF_KEYS,
    FitLight,
    FitScene,
    Material,
    build_scene,
    flat_normal_texture,
    shaded_texture,
    texel_centres,
)
from clothscope.fit.repeat import ShiftedSamples, on_device, repeat_penalty
from clothscope.fit.target import Target, image_loss
from clothscope.prepare.shading import shading


@dataclass(frozen=True)
class NormalSettings:
    """Knobs of the normal-map stage (``fit.normals`` in the config schema, which holds the defaults)."""

    resolution: int
    spp: int  # samples per pixel of the image the loss compares with the photo
    spp_grad: int  # samples per pixel of the gradient pass (0: same as spp)
    sampler: str  # Mitsuba sampler of the stage's renders
    texture: int
    iterations: int
    learning_rate: float
    patience: int
    min_improvement: float
    joint_iterations: int
    joint_learning_rate: float
    joint_height_learning_rate: float  # the height map's step in the joint phase (the BSDF's is joint_learning_rate)
    min_roughness: float
    albedo_weight: float  # > 0: fit a shade texture with this L1 prior weight (0: one colour)
    smoothness: float  # weight of the curvature prior: mean squared Laplacian of the height map (texel units)
    large_steps_lambda: float  # > 0: the height map descends in Large Steps coordinates (I + lambda L) h, Uniform Adam
    near_camera_deg: float  # a fitted light within this angle of the camera raises the curvature prior ...
    near_camera_smoothness: float  # ... to at least this weight (see relief_prior)
    colour_model: str  # auto, one_colour or dye_layout (clothscope.fit.colour)
    layout_mixing: str  # hard or mixed: the dye layout's pixel colours (clothscope.fit.colour.layout_texture)
    initial_relief: str  # flat, or shading: the height map starts bright-high, dark-low (see initial_height)
    initial_slope: float  # RMS slope of the shading start (tangent of the tilt)
    seed_cycle: int  # > 0: iterations cycle through this many seeds and the renders reuse their intersections
    cavity: float  # > 0: the base colour is darkened where the height lies below its ring mean (see cavity_factor)
    repeat_weight: float  # > 0: weight of the prior that the height map repeats where the photo does (clothscope.fit.repeat)


#: Logistic latent of a shade of 1 (the shade texture's start and prior centre); s0 = sigmoid(SHADE_LATENT0).
SHADE_LATENT0 = 2.0


def offset_indices(size: int, dy: int, dx: int) -> np.ndarray:
    """Flat indices of the texel ``(dy, dx)`` away from each texel of a (size, size) grid (clamped at the border)."""
    rows, cols = np.meshgrid(np.arange(size), np.arange(size), indexing="ij")
    return (np.clip(rows + dy, 0, size - 1) * size + np.clip(cols + dx, 0, size - 1)).reshape(-1).astype(np.uint32)


def neighbour_indices(size: int) -> dict[str, np.ndarray]:
    """Flat indices of each texel's left/right/up/down neighbour (clamped at the border)."""
    return {"left": offset_indices(size, 0, -1), "right": offset_indices(size, 0, 1),
            "up": offset_indices(size, -1, 0), "down": offset_indices(size, 1, 0)}


#: Radius (texels) of the ring whose mean height a texel's depth is measured from (the cavity factor).
CAVITY_RADIUS = 3


def ring_indices(size: int, radius: int) -> list[np.ndarray]:
    """Flat indices of the eight texels ``radius`` away along the axes and diagonals (clamped at the border)."""
    diagonal = max(int(round(radius / np.sqrt(2))), 1)
    offsets = [(0, radius), (0, -radius), (radius, 0), (-radius, 0),
               (diagonal, diagonal), (diagonal, -diagonal), (-diagonal, diagonal), (-diagonal, -diagonal)]
    return [offset_indices(size, dy, dx) for dy, dx in offsets]


def cavity_factor(mi: ModuleType, height: Any, ring: list[Any], strength: float) -> Any:
    """Differentiable per-texel factor ``2 sigmoid(-strength * d)`` in (0, 2), ``d`` = ring mean height minus the height."""
    ring_mean = sum(dr.gather(mi.Float, height, index) for index in ring) / len(ring)
    return 2.0 * sigmoid(-strength * (ring_mean - height))


def cavity_factor_np(height: np.ndarray, strength: float) -> np.ndarray:
    """:func:`cavity_factor` of a (T, T) height map, numpy version."""
    flat = height.reshape(-1)
    ring_mean = np.mean([flat[index] for index in ring_indices(height.shape[0], CAVITY_RADIUS)], axis=0)
    return (2.0 * expit(-strength * (ring_mean - flat))).reshape(height.shape)


def height_to_normals_np(height: np.ndarray) -> np.ndarray:
    """(T, T, 3) unit tangent-space normals of a height map (rows toward -y), numpy version."""
    padded = np.pad(height, 1, mode="edge")
    dx = (padded[1:-1, 2:] - padded[1:-1, :-2]) / 2
    dy = -(padded[2:, 1:-1] - padded[:-2, 1:-1]) / 2  # row index grows toward -y
    normal = np.stack([-dx, -dy, np.ones_like(dx)], axis=-1)
    return normal / np.linalg.norm(normal, axis=-1, keepdims=True)


#: Width (working pixels) of the Gaussian whose blur is taken out of the shading start: fold-scale shading is the mesh's.
RELIEF_HIGHPASS_PX = 16.0


def initial_height(photo: np.ndarray, size: int, margin: float, slope: float) -> np.ndarray:
    """(size * size,) start of the height map: the photo's shading high-passed, bright high and dark low ("dark is deep").

    Crevices between yarns and holes are dark under most lights (occlusion), yarn crowns bright; the dye layout is
    divided out (:func:`clothscope.prepare.shading.shading`) and shading wider than :data:`RELIEF_HIGHPASS_PX` removed. The
    map is resampled onto the texel grid, which overhangs the view by ``margin``, and scaled to an RMS slope of
    ``slope`` (texel widths). A photo with no contrast gives a flat start.
    """
    field = shading(photo.astype(np.float64))
    field = field - ndimage.gaussian_filter(field, RELIEF_HIGHPASS_PX, mode="reflect")
    centres = texel_centres(size, margin) * photo.shape[0] - 0.5  # in photo pixels, 0 at the first pixel's centre
    rows, cols = np.meshgrid(centres, centres, indexing="ij")
    height = ndimage.map_coordinates(field, [rows, cols], order=1, mode="nearest")
    gy, gx = np.gradient(height)
    rms = float(np.sqrt(np.mean(gx**2 + gy**2)))
    if not np.isfinite(rms) or rms < 1e-9:
        return np.zeros(size * size, dtype=np.float32)
    return (height * (slope / rms)).astype(np.float32).ravel()


def normal_texture(mi: ModuleType, height: Any, neighbours: dict[str, Any], size: int) -> Any:
    """Differentiable encoded normal texture (0.5 n + 0.5) of a flat height array."""
    g = lambda key: dr.gather(mi.Float, height, neighbours[key])  # noqa: E731
    dx = (g("right") - g("left")) * 0.5
    dy = -(g("down") - g("up")) * 0.5
    n = dr.normalize(mi.Vector3f(-dx, -dy, 1.0))
    return mi.TensorXf(dr.ravel(n * 0.5 + 0.5), shape=(size, size, 3))


def curvature(mi: ModuleType, height: Any, neighbours: dict[str, Any]) -> Any:
    """Differentiable 4-neighbour Laplacian of a flat height array (clamped at the border)."""
    g = lambda key: dr.gather(mi.Float, height, neighbours[key])  # noqa: E731
    return g("left") + g("right") + g("up") + g("down") - 4.0 * height


def height_of(steps: HeightSteps | None, latent: Any) -> Any:
    """Differentiable flat heights of the optimiser's variable (the heights themselves when ``steps`` is None)."""
    return latent if steps is None else steps.from_differential(latent)


def shade_of(mi: ModuleType, latent: Any) -> Any:
    """Per-texel shade (1 at :data:`SHADE_LATENT0`) of its logistic latent."""
    return sigmoid(latent) / float(expit(SHADE_LATENT0))


def albedo_texture(mi: ModuleType, color_latent: Any, size: int, shade_latent: Any = None,
                   layout: tuple[Any, Any, Any] | None = None, cavity: Any = None) -> Any:
    """Differentiable (size, size, 3) base-colour texture: the material colour times the shade, the cavity factor and the dye layout."""
    color = [sigmoid(dr.gather(mi.Float, color_latent, i)) for i in range(3)]
    if shade_latent is not None:
        shade = shade_of(mi, shade_latent)
        color = [c * shade for c in color]
    if cavity is not None:
        color = [c * cavity for c in color]
    if layout is not None:
        color = [c * ratio for c, ratio in zip(color, layout)]
    return mi.TensorXf(dr.ravel(mi.Color3f(*color)), shape=(size, size, 3))  # a shade, cavity or layout makes it per texel


def relief_prior(settings: NormalSettings, light: FitLight) -> tuple[NormalSettings, dict[str, Any]]:
    """The settings the stage fits with under ``light``, and the record of the choice.

    A light within ``settings.near_camera_deg`` of the camera (on the +z axis, so the
    angle is the light's polar angle) raises ``smoothness`` to ``near_camera_smoothness``
    when that is larger; any other light leaves the settings as they are.
    """
    near = light.polar_deg < settings.near_camera_deg
    smoothness = max(settings.smoothness, settings.near_camera_smoothness) if near else settings.smoothness
    reason = f"light {light.polar_deg:.1f} deg from the camera" + (f", within {settings.near_camera_deg:g}" if near else "")
    reason += f": curvature prior {smoothness:g}" if smoothness > 0 else ": no curvature prior"
    record = {"light_from_camera_deg": float(light.polar_deg), "near_camera": bool(near), "smoothness": float(smoothness),
              "reason": reason}
    return replace(settings, smoothness=smoothness), record


def stage_integrator(plan: Plan, seed_cycle: int) -> dict[str, Any]:
    """The plan's integrator; with ``seed_cycle`` > 0, ours keeps the intersections of the cycle's primal and gradient renders."""
    integrator = plan.integrator_dict()
    if seed_cycle > 0 and integrator["type"] == UNSHADOWED:
        integrator["intersection_cache"] = 2 * seed_cycle
    return integrator


def fit_normals(mi: ModuleType, fit: FitScene, target: Target, plan: Plan, settings: NormalSettings,
                log: logging.Logger, colour: ColourModel | None, sample_seed: int,
                repeats: list[ShiftedSamples] | None = None) -> tuple[np.ndarray, Material, list[Any], np.ndarray | None]:
    """Fit the height map (and shade), then with the BSDF jointly; returns height, material, loop results, shade.

    ``colour``: the base colour's model (:mod:`.colour`); its layout texture must be ``settings.texture`` texels wide.
    ``sample_seed`` is the config's ``fit.sample_seed`` (which render samples the steps draw). ``repeats``: the
    photo's translations as gathers of the ``settings.texture`` map (:func:`clothscope.fit.repeat.repeat_samples`),
    weighted by ``settings.repeat_weight`` in the loss; None or [] for no repeat prior.
    """
    size = settings.texture
    shaded = settings.albedo_weight > 0
    layout_np = None if colour is None else colour.layout
    cavity = settings.cavity > 0
    textured = shaded or layout_np is not None or cavity
    layout = None if layout_np is None else tuple(mi.Float(layout_np[..., c].ravel()) for c in range(3))
    scene = build_scene(mi, fit, target.resolution, stage_integrator(plan, settings.seed_cycle), settings.sampler,
                        normal_texture=flat_normal_texture(size), sample_border=plan.projective,
                        albedo_texture=shaded_texture(fit.material, np.ones((size, size)), layout_np) if textured else None)
    params = mi.traverse(scene)
    neighbours = {k: mi.UInt32(v) for k, v in neighbour_indices(size).items()}
    ring = [mi.UInt32(index) for index in ring_indices(size, CAVITY_RADIUS)] if cavity else []
    fixed = material_latents(fit.material, settings.min_roughness)
    fixed_arrays = {k: mi.Float(v) for k, v in fixed.items()}  # device copies made once, used while the BSDF is held
    steps = HeightSteps(size, settings.large_steps_lambda) if settings.large_steps_lambda > 0 else None
    repeat_gathers = on_device(mi, repeats or []) if settings.repeat_weight > 0 else []

    def loss_fn(opt, render_seed):
        height = height_of(steps, opt["height"])
        params[BSDF_KEYS["normalmap"]] = normal_texture(mi, height, neighbours, size)
        latents = {k: opt[k] if k in opt else fixed_arrays[k] for k in fixed}
        apply_material(mi, params, latents, settings.min_roughness, textured=textured)
        if textured:
            params[BSDF_KEYS["albedo"]] = albedo_texture(mi, latents["color"], size, opt["shade"] if shaded else None, layout,
                                                         cavity_factor(mi, height, ring, settings.cavity) if cavity else None)
        params.update()
        loss = image_loss(mi, render(mi, scene, params, settings.spp, render_seed, settings.spp_grad), target)
        if settings.smoothness > 0:
            loss = loss + settings.smoothness * dr.mean(dr.square(curvature(mi, height, neighbours)))
        if shaded:
            loss = loss + settings.albedo_weight * dr.mean(dr.abs(shade_of(mi, opt["shade"]) - 1.0))
        if repeat_gathers:
            loss = loss + settings.repeat_weight * repeat_penalty(mi, height, repeat_gathers)
        return loss

    start = (initial_height(target.image, size, fit.margin, settings.initial_slope) if settings.initial_relief == "shading"
             else np.zeros(size * size, dtype=np.float32))
    height0 = {"height": start if steps is None else steps.to_differential(start)}
    if shaded:
        height0["shade"] = np.full(size * size, SHADE_LATENT0, dtype=np.float32)
    uniform = steps is not None
    first = optimise(mi, height0, loss_fn, LoopSettings(settings.iterations, settings.learning_rate, settings.patience,
                                                        settings.min_improvement, uniform=uniform, sample_seed=sample_seed,
                                                        seed_cycle=settings.seed_cycle), log, "normals")
    joint_start = first.best | fixed
    heights = lambda latents: np.asarray(latents["height"] if steps is None else steps.solve(latents["height"]),  # noqa: E731
                                         dtype=np.float64).reshape(size, size)
    if settings.joint_iterations == 0:  # BSDF kept from the material stage
        height = heights(first.best)
        return height, fit.material, [first], _shade(first.best, size, height, settings.cavity)
    # the joint phase runs all its iterations and keeps the last iterate: its noisy loss flattens long before the
    # roughness stops drifting, and the lowest noisy loss would favour rough lobes (see clothscope.fit.loop)
    second = optimise(mi, joint_start, loss_fn, LoopSettings(settings.joint_iterations, settings.joint_learning_rate,
                                                             keep="last", uniform=uniform,
                                                             rates={"height": settings.joint_height_learning_rate}, sample_seed=sample_seed,
                                                             seed_cycle=settings.seed_cycle),
                     log, "normals+bsdf")
    best = second.best if second.best_loss <= first.best_loss else joint_start
    material = material_from_latents({k: best[k] for k in fixed}, settings.min_roughness)
    height = heights(best)
    return height, material, [first, second], _shade(best, size, height, settings.cavity)


def _shade(latents: dict[str, np.ndarray], size: int, height: np.ndarray, cavity: float) -> np.ndarray | None:
    """The fitted (size, size) multiplier of the material colour (shade times cavity factor), or None without one."""
    shade = None
    if "shade" in latents:
        shade = (expit(latents["shade"].astype(np.float64)) / expit(SHADE_LATENT0)).reshape(size, size)
    if cavity > 0:
        shade = cavity_factor_np(height, cavity) * (1.0 if shade is None else shade)
    return shade
