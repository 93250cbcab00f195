"""One Snakemake job per stage and image: read inputs, fit, write every output atomically.

A stage whose input was rejected or skipped upstream writes a ``state.json``
with ``status: skipped`` and its reason instead of failing, so one bad image
never sinks the run. Any other failure is recorded the same way with
``status: failed`` and a one-line reason (the traceback goes to the log).
"""
from __future__ import annotations

import logging
import os
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from clothscope.core.atomic import atomic_dir, write_json, write_text
from clothscope.core.imageio import write_exr, write_png
from clothscope.core.runtime import mitsuba_for, runtime_metadata
from clothscope.fit.colour import choose_colour_model
from clothscope.fit.effects import geometry_evidence, plan_stage
from clothscope.fit.geometry import GeometrySettings, fit_geometry
from clothscope.fit.material import MaterialSettings, fit_material_and_light
from clothscope.fit.model import PREVIEW_SAMPLER, FitScene, build_scene, shaded_texture, soft_light_map
from clothscope.fit.normals import NormalSettings, fit_normals, height_to_normals_np, relief_prior
from clothscope.fit.outputs import (
    ALBEDO_FILE,
    COMPARISON_FILE,
    HEIGHT_FILE,
    LIGHT_FILE,
    LOSS_FILE,
    MATERIAL_FILE,
    MESH_FILE,
    NORMAL_FILE,
    NORMAL_PNG_FILE,
    SCENE_FILE,
    SHADE_FILE,
    STATE_FILE,
    load_state,
    save_state,
    scene_xml,
    write_comparison,
    write_loss_curve,
)
from clothscope.fit.repeat import repeat_samples
from clothscope.fit.target import SkipStage, Target, at_resolution, load_prepared, psnr, unexplained_share

PREVIEW_SPP = 35  # a 5 x 7 multijitter grid (asked for 32, the sampler drew 35)


def _run_job(out_dir: str | os.PathLike[str], stage: str, log: logging.Logger,
             body: Callable[[Path], dict[str, Any]]) -> dict[str, Any]:
    """Run ``body(tmp_dir)`` inside an atomic output folder; record skips and failures."""
    started = time.perf_counter()
    with atomic_dir(out_dir) as tmp:
        try:
            record = body(tmp) | {"status": "fitted"}
        except SkipStage as skip:
            record = {"status": "skipped", "reason": str(skip)}
        except Exception as err:  # noqa: BLE001 - one image must not sink the run
            log.error("%s", traceback.format_exc())
            record = {"status": "failed", "reason": f"{stage}: {type(err).__name__}: {(str(err).splitlines() or [''])[0]}"}
        record |= {"stage": stage, "seconds": round(time.perf_counter() - started, 3)}
        if record["status"] != "fitted":
            log.warning("%s %s: %s", stage, record["status"], record["reason"])
            write_json(tmp / STATE_FILE, record)
    return record


def _render_fit(mi: Any, fit: FitScene, resolution: int, texture: np.ndarray | None = None,
                albedo: np.ndarray | None = None) -> tuple[np.ndarray, Any]:
    """The fit re-rendered at ``resolution`` (linear RGB) and the scene it was rendered from."""
    scene = build_scene(mi, fit, resolution, {"type": "direct"}, PREVIEW_SAMPLER, normal_texture=texture, albedo_texture=albedo)
    return np.array(mi.render(scene, spp=PREVIEW_SPP, seed=7), dtype=np.float32)[..., :3], scene


def _write_common(tmp: Path, mi: Any, fit: FitScene, photo: Target, curve: list[dict[str, float]],
                  record: dict[str, Any], texture: np.ndarray | None, normal_file: str | None,
                  albedo: np.ndarray | None = None) -> dict[str, Any]:
    """Outputs every stage writes: loss curve, side-by-side PNG, mesh, scene file and state (with the preview's PSNR
    and the share of the photo it leaves unexplained)."""
    rendered, scene = _render_fit(mi, fit, photo.resolution, texture, albedo)
    record["psnr_db"] = psnr(rendered, photo)
    record["unexplained_share"] = unexplained_share(rendered, photo)
    write_loss_curve(tmp / LOSS_FILE, curve)
    write_comparison(tmp / COMPARISON_FILE, photo, rendered)
    scene.shapes()[0].write_ply(str(tmp / MESH_FILE))
    if albedo is not None:
        write_exr(tmp / ALBEDO_FILE, albedo)
    if fit.light.spread_deg > 0:
        write_exr(tmp / LIGHT_FILE, soft_light_map(fit.light))
    write_text(tmp / SCENE_FILE, scene_xml(fit, MESH_FILE, normal_file, photo.resolution,
                                            albedo_file=None if albedo is None else ALBEDO_FILE))
    save_state(tmp, fit, record | {"runtime": runtime_metadata(mi)})
    return record


def _continue_fit(previous_dir: str, prepared_dir: str, stage: str, variant: str, threads: int, full_effects: bool,
                  log: logging.Logger) -> tuple[FitScene, Target, Any, Any]:
    """Fit scene of the previous stage, the photo, Mitsuba and this stage's effects plan."""
    fit, _ = load_state(previous_dir)
    photo = load_prepared(prepared_dir)
    mi = mitsuba_for(variant, threads)
    plan = plan_stage(stage, geometry_evidence(fit.grid, fit.camera, fit.light), full_effects)
    log.info("effects plan: %s (%s)", plan.integrator, "; ".join(plan.reasons))
    return fit, photo, mi, plan


def geometry_job(prepared_dir: str, out_dir: str, settings: GeometrySettings, variant: str, threads: int,
                 full_effects: bool, log: logging.Logger, sample_seed: int) -> dict[str, Any]:
    """``fit_geometry`` for one image (``sample_seed``: the config's ``fit.sample_seed``)."""
    def body(tmp: Path) -> dict[str, Any]:
        photo = load_prepared(prepared_dir)
        mi = mitsuba_for(variant, threads)
        fit, record = fit_geometry(mi, photo, settings, full_effects, log, sample_seed)
        curve = record.pop("curve")
        return _write_common(tmp, mi, fit, photo, curve, record, None, None)

    return _run_job(out_dir, "geometry", log, body)


def material_job(prepared_dir: str, geometry_dir: str, out_dir: str, settings: MaterialSettings, variant: str,
                 threads: int, full_effects: bool, log: logging.Logger, sample_seed: int) -> dict[str, Any]:
    """``fit_material`` for one image (``sample_seed``: the config's ``fit.sample_seed``)."""
    def body(tmp: Path) -> dict[str, Any]:
        fit, photo, mi, plan = _continue_fit(geometry_dir, prepared_dir, "material", variant, threads, full_effects, log)
        fit.light, fit.material, loop, light_choice = fit_material_and_light(mi, fit, at_resolution(photo, settings.resolution), plan,
                                                                            settings, log, sample_seed)
        record = {"effects": [plan.as_record()], "warnings": loop.warnings, "stopped": loop.stopped, "light_choice": light_choice,
                  "final_loss": loop.best_loss, "settings": settings.__dict__, "sample_seed": sample_seed, "material": fit.material.as_dict()}
        write_json(tmp / MATERIAL_FILE, {"material": fit.material.as_dict(), "effects": [plan.as_record()],
                                           "warnings": loop.warnings})
        return _write_common(tmp, mi, fit, photo, [r | {"phase": "material"} for r in loop.curve], record, None, None)

    return _run_job(out_dir, "material", log, body)


def normals_job(prepared_dir: str, material_dir: str, out_dir: str, settings: NormalSettings, variant: str,
                threads: int, full_effects: bool, log: logging.Logger, sample_seed: int) -> dict[str, Any]:
    """``fit_normals`` for one image: normal map, height map, preview and the refined BSDF (``sample_seed``: ``fit.sample_seed``)."""
    def body(tmp: Path) -> dict[str, Any]:
        fit, photo, mi, plan = _continue_fit(material_dir, prepared_dir, "normals", variant, threads, full_effects, log)
        colour = choose_colour_model(settings.colour_model, photo.image, settings.texture, fit.margin, settings.layout_mixing)
        log.info("colour model: %s", colour.as_record())
        fitted_with, prior = relief_prior(settings, fit.light)
        log.info("relief prior: %s", prior["reason"])
        target = at_resolution(photo, settings.resolution)
        repeats, repeat_record = repeat_samples(target.image, settings.texture, fit.margin)
        repeat_record = {"weight": float(settings.repeat_weight)} | repeat_record
        log.info("repeat prior: weight %g, %s", settings.repeat_weight, repeat_record["reason"])
        height, fit.material, loops, shade = fit_normals(mi, fit, target, plan, fitted_with, log, colour, sample_seed, repeats)
        normals = height_to_normals_np(height).astype(np.float32)
        write_exr(tmp / NORMAL_FILE, normals)
        write_exr(tmp / HEIGHT_FILE, np.repeat(height[..., None], 3, axis=2).astype(np.float32))
        if shade is not None:
            write_exr(tmp / SHADE_FILE, np.repeat(shade[..., None], 3, axis=2).astype(np.float32))
        write_png(tmp / NORMAL_PNG_FILE, normals * 0.5 + 0.5)
        texels_per_pixel = settings.texture / (photo.resolution * (1 + fit.margin))
        record = {"effects": [plan.as_record()], "warnings": [w for loop in loops for w in loop.warnings],
                  "stopped": [loop.stopped for loop in loops], "final_loss": min(loop.best_loss for loop in loops),
                  "settings": settings.__dict__, "sample_seed": sample_seed, "material": fit.material.as_dict(), "texels_per_pixel": texels_per_pixel,
                  "colour_model": colour.as_record(), "relief_prior": prior, "repeat_prior": repeat_record}
        write_json(tmp / MATERIAL_FILE, {"material": fit.material.as_dict(), "effects": [plan.as_record()],
                                           "refined_jointly_with_normal_map": True, "texels_per_pixel": texels_per_pixel,
                                           "colour_model": colour.as_record()})
        curve = [r | {"phase": phase} for phase, loop in zip(("normals", "normals+bsdf"), loops) for r in loop.curve]
        textured = shade is not None or colour.layout is not None
        albedo = shaded_texture(fit.material, np.ones(normals.shape[:2]) if shade is None else shade, colour.layout) if textured else None
        return _write_common(tmp, mi, fit, photo, curve, record, normals * 0.5 + 0.5, NORMAL_PNG_FILE, albedo)

    return _run_job(out_dir, "normals", log, body)
