"""Benchmark: the normal-map stage's iteration with Mitsuba's backward pass, with ours, and frozen (``dr.freeze``).

    .venv/bin/python workflow/benchmarks/backward_pass.py [--run results] [--images SUBSET] [--steps 60]
        [--variant llvm_ad_rgb] [--ways mitsuba direct "direct, frozen"] [--no-texture-accel] [--name backward_pass]

On a CUDA GPU (where tracing, which freezing removes, is expected to be a larger share of a
step): ``--variant cuda_ad_rgb --name backward_pass_cuda``; ``--no-texture-accel`` builds the
normal map without CUDA's hardware texture.

For each image it builds the normal-map stage's scene from the run's material
stage (``<run>/fit/<image>/material``) and prepared photo, and runs the stage's
step (normal texture of the height map, render, image loss, backward pass,
Adam step) from a flat height map, in up to three ways (``--ways``; the first is the
reference), one after the other per image, each in a process of its own:

- ``mitsuba``: Mitsuba's ``ADIntegrator.render_backward``, which renders the
  image into a block before it propagates the image's adjoint;
- ``direct``: :class:`clothscope.fit.integrator` hands each sample its pixel's
  adjoint (what the fit runs);
- ``direct, frozen``: the same step recorded once by ``dr.freeze`` and replayed
  (the render and its backward pass called directly, since ``mi.render`` reads
  its seeds on the host, which a recording cannot do).

It reports the milliseconds per step after ``--warm-up`` steps (alone on
``--threads`` threads: run it on an otherwise idle machine), the largest
difference between the first step's gradients of each way and the reference
(same seeds) relative to the largest gradient, and the largest difference of
the height maps after the last step. A way that raises or crashes its process
gets its error in its row instead. Writes ``results/bench/<name>.{csv,md}``.
"""
from __future__ import annotations

import argparse
import logging
import multiprocessing
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from harness import ROOT, SUBSET, publish, validated_config

VARIANTS = ("mitsuba", "direct", "direct, frozen")


def stage_scene(mi: Any, run: Path, image: str, resolution: int, texture: int, sampler: str,
                texture_accel: bool = True) -> tuple[Any, Any]:
    """The normal-map stage's scene (flat normal map, the stage's ``sampler``) of ``image`` and its photo at ``resolution``.

    ``texture_accel=False`` builds the normal map as a bitmap without CUDA's hardware texture
    (Mitsuba's ``accel`` parameter), whose update a ``dr.freeze`` recording cannot follow.
    """
    from clothscope.fit.effects import geometry_evidence, plan_stage
    from clothscope.fit.model import build_scene, flat_normal_texture
    from clothscope.fit.outputs import load_state
    from clothscope.fit.target import at_resolution, load_prepared

    fit, _ = load_state(run / "fit" / image / "material")
    plan = plan_stage("normals", geometry_evidence(fit.grid, fit.camera, fit.light))
    if plan.integrator != "direct_unshadowed":
        raise ValueError(f"{image}: the normal-map stage plans {plan.integrator}, not direct_unshadowed")
    scene = build_scene(mi, fit, resolution, plan.integrator_dict(), sampler, normal_texture=flat_normal_texture(texture),
                        normal_accel=texture_accel)
    return scene, at_resolution(load_prepared(run / "prepared" / image), resolution)


def step_function(mi: Any, scene: Any, target: Any, texture: int, spp: int, spp_grad: int, frozen: bool) -> Callable:
    """``step(height, seed) -> loss``: the stage's render, loss and backward pass (gradient left on ``height``)."""
    import drjit as dr

    from clothscope.fit.loop import render
    from clothscope.fit.model import BSDF_KEYS
    from clothscope.fit.normals import neighbour_indices, normal_texture
    from clothscope.fit.target import image_loss

    neighbours = {k: mi.UInt32(v) for k, v in neighbour_indices(texture).items()}
    params = mi.traverse(scene)
    if not frozen:
        def step(height, seed):
            params[BSDF_KEYS["normalmap"]] = normal_texture(mi, height, neighbours, texture)
            params.update()
            loss = image_loss(mi, render(mi, scene, params, spp, seed, spp_grad), target)
            dr.backward(loss)
            return loss
        return step

    integrator, sensor = scene.integrator(), scene.sensors()[0]
    image_loss(mi, dr.zeros(mi.TensorXf, target.image.shape), target)  # its device constants, made before recording

    @dr.freeze
    def frozen_step(scene, height, seed, target):
        params[BSDF_KEYS["normalmap"]] = normal_texture(mi, height, neighbours, texture)
        params.update()
        with dr.suspend_grad():
            image = integrator.render(scene, sensor, seed=seed, spp=spp, develop=True, evaluate=False)
        image = dr.detach(image)
        dr.enable_grad(image)
        loss = image_loss(mi, image, target)
        dr.backward(loss)
        integrator.render_backward(scene, params, dr.grad(image), sensor, seed=seed + 100_003, spp=spp_grad)
        return loss

    return lambda height, seed: frozen_step(scene, height, mi.UInt32(seed), target)


def descend(mi: Any, step: Callable, texture: int, iterations: int, warm_up: int, learning_rate: float) -> tuple[float, np.ndarray, np.ndarray]:
    """Run ``iterations`` Adam steps from a flat map: ms per step after ``warm_up``, first gradient, last heights."""
    import drjit as dr

    opt = mi.ad.Adam(lr=learning_rate, params={"height": mi.Float(np.zeros(texture * texture, dtype=np.float32))})
    first_gradient = None
    for it in range(iterations):
        if it == warm_up:
            dr.sync_thread()
            started = time.perf_counter()
        loss = step(opt["height"], it)
        float(loss.array[0])  # the loop reads every loss (plateau rule, restarts)
        if first_gradient is None:
            first_gradient = np.array(dr.grad(opt["height"]))
        opt.step()
    dr.eval(opt["height"])
    dr.sync_thread()
    return 1000 * (time.perf_counter() - started) / (iterations - warm_up), first_gradient, np.array(opt["height"])


def measure_way(run: Path, image: str, way: str, iterations: int, warm_up: int, threads: int, variant: str,
                texture_accel: bool = True) -> tuple[float, np.ndarray, np.ndarray]:
    """ms per step, first gradient and last heights of ``way`` on ``image`` (run in a process of its own)."""
    from clothscope.core.runtime import mitsuba_for
    from clothscope.fit import integrator

    settings = validated_config()["fit"]["normals"]
    mi = mitsuba_for(variant, threads)
    if way == "mitsuba":
        integrator.splats_one_pixel_per_sample = lambda film: False
    scene, target = stage_scene(mi, run, image, settings["resolution"], settings["texture"], settings["sampler"],
                                texture_accel)
    step = step_function(mi, scene, target, settings["texture"], settings["spp"], settings["spp_grad"],
                         frozen=way.endswith("frozen"))
    try:
        return descend(mi, step, settings["texture"], iterations, warm_up, settings["learning_rate"])
    except Exception as error:  # Dr.Jit chains the recording's cause under a generic message: keep the cause
        causes, cause = [], error
        while cause is not None:
            causes.append(str(cause))
            cause = cause.__cause__ or cause.__context__
        raise RuntimeError(causes[-1]) from None


def in_own_process(function: Callable, *args: Any) -> tuple[Any, str]:
    """``(result, "")`` of ``function(*args)`` in a fresh process, or ``(None, why)`` where it raised or the process died."""
    try:
        with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
            return pool.submit(function, *args).result(), ""
    except BrokenProcessPool:
        return None, "the process died (a Dr.Jit error; its message is on standard error)"
    except Exception as error:  # noqa: BLE001 - a way that fails is a finding, reported in its row
        return None, " ".join(str(error).split())[:200]


def measure(run: Path, images: list[str], iterations: int, warm_up: int, threads: int, variant: str,
            ways: tuple[str, ...] = VARIANTS, texture_accel: bool = True) -> pd.DataFrame:
    """One row per image and way, each in a fresh process (a second frozen recording crashed Dr.Jit 1.5); a way that fails gets its error."""
    rows = []
    for image in images:
        results = {way: in_own_process(measure_way, run, image, way, iterations, warm_up, threads, variant, texture_accel)
                   for way in ways}
        reference = results[ways[0]][0]
        for way, (result, error) in results.items():
            row = {"image_id": image, "variant": way, "mitsuba_variant": variant, "ms_per_step": np.nan,
                   "first_gradient_difference": np.nan, "height_difference": np.nan, "error": error}
            if result is not None:
                row["ms_per_step"] = result[0]
            if result is not None and reference is not None:
                scale = float(np.abs(reference[1]).max()) or 1.0
                row["first_gradient_difference"] = float(np.abs(result[1] - reference[1]).max()) / scale
                row["height_difference"] = float(np.abs(result[2] - reference[2]).max())
            rows.append(row)
            logging.info("%s, %s: %s", image, way, error or f"{row['ms_per_step']:.1f} ms")
    return pd.DataFrame(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", type=Path, default=ROOT / "results", help="a finished run (material stage and prepared photos)")
    parser.add_argument("--images", default=SUBSET, help="comma-separated image ids (default: one per class)")
    parser.add_argument("--steps", type=int, default=60, help="Adam steps per variant and image")
    parser.add_argument("--warm-up", type=int, default=10)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--variant", default="llvm_ad_rgb", choices=("llvm_ad_rgb", "cuda_ad_rgb"), help="Mitsuba variant")
    parser.add_argument("--name", default="backward_pass", help="report name (<out>/<name>.{csv,md})")
    parser.add_argument("--ways", nargs="+", default=list(VARIANTS), choices=VARIANTS,
                        help="ways to run, the first the reference (default: all three)")
    parser.add_argument("--no-texture-accel", action="store_true",
                        help="normal map without CUDA's hardware texture (Mitsuba's bitmap `accel`)")
    args = parser.parse_args()
    if not 0 <= args.warm_up < args.steps:
        raise SystemExit(f"--warm-up must lie in [0, --steps), got {args.warm_up} and {args.steps}")
    ways = tuple(args.ways)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    table = measure(args.run, [i for i in args.images.split(",") if i], args.steps, args.warm_up, args.threads,
                    args.variant, ways, not args.no_texture_accel)
    summary = table.groupby("variant", sort=False).agg(
        images=("ms_per_step", "count"), failed=("error", lambda e: int((e != "").sum())),
        median_ms_per_step=("ms_per_step", "median"),
        max_first_gradient_difference=("first_gradient_difference", "max"), max_height_difference=("height_difference", "max"))
    summary = summary[summary["images"] > 0]
    if ways[0] in summary.index:
        summary[f"time against {ways[0]}"] = summary["median_ms_per_step"] / summary.loc[ways[0], "median_ms_per_step"]
    failures = table[table["error"] != ""]
    config = validated_config()["fit"]["normals"]
    lines = [f"The normal-map stage's step ({config['resolution']} px, {config['spp']} + {config['spp_grad']} spp, "
             f"{config['texture']} texels) from a flat height map, {args.steps} steps of which the last "
             f"{args.steps - args.warm_up} are timed, `{args.variant}`, alone on "
             f"{'the GPU' if args.variant.startswith('cuda') else f'{args.threads} threads'}, "
             f"{'normal map without the hardware texture (`accel` off), ' if args.no_texture_accel else ''}"
             f"each way and image in a process of its own; the ways ({', '.join(ways)}) "
             "run one after the other per image.", "",
             summary.reset_index().to_markdown(index=False, floatfmt=".3g"), "",
             f"Gradient difference: the largest difference of the first step's gradient from `{ways[0]}`'s (same seeds), "
             f"over `{ways[0]}`'s largest gradient. Height difference: the largest difference of the height map after the "
             f"last step from `{ways[0]}`'s, in texel widths."]
    lines += ["", "Ways that failed:", ""] + [f"- `{r.variant}` on {r.image_id}: {r.error}"
                                              for r in failures.itertuples()] if len(failures) else []
    publish(args.out, args.name, table, "\n".join(lines) + "\n", float_format="%.4g")


if __name__ == "__main__":
    main()
