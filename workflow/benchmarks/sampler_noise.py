"""Benchmark: the noise a fit render leaves per sample, for each Mitsuba sampler, on fitted scenes.

Rebuilds each image's fitted scene from ``results/fit/<id>/normals`` (mesh,
BSDF, normal map and any base-colour texture; run ``snakemake`` first), as the
fit renders it (emitter sampling without shadow rays, one point light), and
renders it twice per sampler and sample count with different seeds. The noise
of one render is ``sqrt(mean((a - b)^2) / 2)`` over pixels and channels, which
needs no reference image; it is reported relative to the render's root mean
square. The milliseconds are one render's median wall time on one Dr.Jit thread.

    .venv/bin/python workflow/benchmarks/sampler_noise.py [--images canvas_red,satin_red]

Writes ``results/bench/sampler_noise.csv`` (one row per image, sampler and
sample count) and ``results/bench/sampler_noise.md`` (medians over the images).
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd
from harness import ROOT, SUBSET, publish

from clothscope.core.config import SCHEMA_PATH, schema_defaults
from clothscope.core.imageio import read_exr
from clothscope.core.runtime import mitsuba_for
from clothscope.core.schema import load_schema
from clothscope.fit.integrator import NAME as UNSHADOWED
from clothscope.fit.model import build_scene
from clothscope.fit.outputs import ALBEDO_FILE, NORMAL_FILE, STATE_FILE, load_state

#: the samplers a fit stage may use (``fit.normals.sampler`` in the config schema)
SAMPLERS = tuple(load_schema(SCHEMA_PATH)
                 ["properties"]["fit"]["properties"]["normals"]["properties"]["sampler"]["enum"])
SAMPLE_COUNTS = (2, 4, 8, 16)
RESOLUTION = 256
REPEATS = 3


def fitted_scene(mi, image: str, sampler: str):
    """The normal-map stage's fitted scene of ``image`` with ``sampler``."""
    folder = ROOT / "results" / "fit" / image / "normals"
    fit, _ = load_state(folder)
    normals = read_exr(folder / NORMAL_FILE)[..., :3]
    albedo = read_exr(folder / ALBEDO_FILE)[..., :3] if (folder / ALBEDO_FILE).is_file() else None
    return build_scene(mi, fit, RESOLUTION, {"type": UNSHADOWED}, sampler, normal_texture=normals * 0.5 + 0.5,
                       albedo_texture=albedo)


def noise_of(mi, scene, spp: int) -> tuple[float, float]:
    """Relative noise of one render at ``spp`` and its median milliseconds."""
    images, seconds = [], []
    for seed in range(REPEATS + 1):
        started = time.perf_counter()
        images.append(np.array(mi.render(scene, spp=spp, seed=1000 + seed), dtype=np.float64))
        seconds.append(time.perf_counter() - started)
    pairs = [np.mean((images[i] - images[i + 1]) ** 2) / 2.0 for i in range(REPEATS)]
    level = np.sqrt(np.mean(np.square(images)))
    return float(np.sqrt(np.mean(pairs)) / max(level, 1e-12)), 1000.0 * float(np.median(seconds[1:]))


def summary(table: pd.DataFrame) -> str:
    medians = table.groupby(["sampler", "spp"], sort=False)[["relative_noise", "ms"]].median().unstack("spp")
    noise = medians["relative_noise"].map(lambda v: f"{100 * v:.2f}%")
    ms = medians["ms"].map(lambda v: f"{v:.0f}")
    noise.columns = [f"noise, {c} spp" for c in noise.columns]
    ms.columns = [f"ms, {c} spp" for c in ms.columns]
    return ("# Render noise per sampler on fitted scenes\n\n"
            f"The normal-map stage renders with `{schema_defaults()['fit']['normals']['sampler']}` (`fit.normals.sampler`). Noise of one "
            f"{RESOLUTION} px render "
            "relative to its root mean square (from pairs of renders with different seeds), and one render's wall "
            f"time on one Dr.Jit thread; medians over {table['image_id'].nunique()} fitted images "
            f"({', '.join(sorted(table['image_id'].unique()))}).\n\n"
            + pd.concat([noise, ms], axis=1).to_markdown() + "\n")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", default=SUBSET, help="comma-separated image ids with a finished fit")
    args = parser.parse_args()
    images = args.images.split(",")
    missing = [i for i in images if not (ROOT / "results" / "fit" / i / "normals" / STATE_FILE).is_file()]
    if missing:
        raise SystemExit(f"sampler_noise: error: no finished fit for {', '.join(missing)} (run snakemake first)")
    mi = mitsuba_for("llvm_ad_rgb", 1)
    rows = []
    for image in images:
        for sampler in SAMPLERS:
            scene = fitted_scene(mi, image, sampler)
            for spp in SAMPLE_COUNTS:
                noise, ms = noise_of(mi, scene, spp)
                rows.append({"image_id": image, "sampler": sampler, "spp": spp, "relative_noise": noise, "ms": ms})
        print(f"{image}: done", flush=True)
    table = pd.DataFrame(rows)
    publish(ROOT / "results" / "bench", "sampler_noise", table, summary(table), float_format="%.6f")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
