"""Benchmark: where the normal-map stage's forward render spends its time.

    .venv/bin/python workflow/benchmarks/render_split.py [--run results] [--images SUBSET] [--calls 15]
        [--threads N] [--variant llvm_ad_rgb] [--name render_split]

The normal-map stage's iteration is a forward render and its backward pass
(``backward_pass.py`` times the whole step). This splits the forward render of the
stage's scene (``backward_pass.stage_scene``: the run's material stage, the stage's
resolution, sampler and ``spp``) into what each part adds, by rendering the same
samples with four integrators that stop after one more part:

- ``camera rays``: the sensor's rays only (sampler, film, splatting);
- ``+ intersection``: and the preliminary ray-mesh intersection (distance, triangle);
- ``+ surface interaction``: and the full surface interaction (position, uv, frames);
- ``+ light and BSDF``: the fit's ``direct_unshadowed`` integrator (one light sample,
  the normal map and the BSDF): the render the fit makes.

Milliseconds per render are medians after ``--warm-up`` renders, alone on
``--threads`` Dr.Jit threads (run it on an otherwise idle machine). The geometry is
fixed in this stage, so the intersection's share bounds what reusing intersections
across iterations could save. Writes ``results/bench/<name>.{csv,md}``.
"""
from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from backward_pass import stage_scene
from harness import ROOT, SUBSET, publish, validated_config

#: the parts, in the order each adds to the one before
PARTS = ("camera rays", "+ intersection", "+ surface interaction", "+ light and BSDF")


def part_integrators(mi: Any) -> dict[str, Any]:
    """One integrator per part of :data:`PARTS`, each returning something that depends on all it computed."""
    from clothscope.fit import integrator

    integrator.register(mi)

    def camera(scene: Any, ray: Any, active: Any) -> Any:
        return mi.Spectrum(ray.d.x, ray.d.y, ray.d.z)

    def preliminary(scene: Any, ray: Any, active: Any) -> Any:
        found = scene.ray_intersect_preliminary(mi.Ray3f(ray), coherent=True, active=active)
        return mi.Spectrum(found.t, found.prim_uv.x, mi.Float(found.prim_index))

    def surface(scene: Any, ray: Any, active: Any) -> Any:
        si = scene.ray_intersect(mi.Ray3f(ray), ray_flags=mi.RayFlags.All, coherent=True, active=active)
        return mi.Spectrum(si.uv.x, si.uv.y, si.sh_frame.n.z)

    made = {}
    for name, part in zip(PARTS, (camera, preliminary, surface)):
        made[name] = mi.load_dict({"type": _registered(mi, f"clothscope_part_{len(made)}", part)})
    made[PARTS[-1]] = mi.load_dict({"type": integrator.NAME})
    return made


def _registered(mi: Any, name: str, part: Callable[[Any, Any, Any], Any]) -> str:
    """Register an integrator whose radiance is ``part(scene, ray, active)``; return its name."""
    class Part(mi.ad.integrators.common.ADIntegrator):
        def sample(self, mode, scene, sampler, ray, depth=None, δL=None, δaovs=None, state_in=None,  # noqa: PLC2401
                   active=True, **kwargs):
            return part(scene, ray, active), mi.Bool(True), [], None

    mi.register_integrator(name, lambda props: Part(props))
    return name


def render_ms(mi: Any, scene: Any, integrator: Any, spp: int, calls: int, warm_up: int) -> float:
    """Median milliseconds of one render of ``scene`` (a new seed each call), after ``warm_up`` calls."""
    import drjit as dr

    times = []
    for seed in range(warm_up + calls):
        start = time.perf_counter()
        dr.eval(mi.render(scene, integrator=integrator, spp=spp, seed=seed))
        times.append(time.perf_counter() - start)
    return float(np.median(times[warm_up:]) * 1000)


def image_rows(run: Path, image: str, variant: str, threads: int, calls: int, warm_up: int, config: dict) -> list[dict]:
    """Milliseconds per render of each part for one image."""
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(variant)
    dr.set_thread_count(threads)
    normals = config["fit"]["normals"]
    scene, _ = stage_scene(mi, run, image, normals["resolution"], normals["texture"], normals["sampler"])
    rows = []
    for name, integrator in part_integrators(mi).items():
        rows.append({"image": image, "part": name, "ms": render_ms(mi, scene, integrator, normals["spp"], calls, warm_up)})
    return rows


def summary(table: pd.DataFrame, settings: str) -> str:
    """Markdown: milliseconds per render of each part, per image and median, and what each part adds."""
    wide = table.pivot(index="image", columns="part", values="ms")[list(PARTS)]
    median = wide.median()
    added = median.diff().fillna(median.iloc[0])
    lines = [f"Forward render of the normal-map stage's scene ({settings}), split by integrators that stop after each "
             "part: milliseconds per render, median over calls; the last column is the fit's own render.", "",
             "| image | " + " | ".join(PARTS) + " |", "|---|" + "---|" * len(PARTS)]
    lines += [f"| {image} | " + " | ".join(f"{row[p]:.1f}" for p in PARTS) + " |" for image, row in wide.iterrows()]
    lines += ["| median | " + " | ".join(f"{median[p]:.1f}" for p in PARTS) + " |",
              "| median share of the render | " + " | ".join(f"{added[p] / median[PARTS[-1]]:.0%}" for p in PARTS) + " |", ""]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", type=Path, default=ROOT / "results", help="a finished run (its material stage is read)")
    parser.add_argument("--images", default=SUBSET, help="comma-separated image ids")
    parser.add_argument("--calls", type=int, default=15, help="timed renders per part and image")
    parser.add_argument("--warm-up", type=int, default=3, help="untimed renders first (tracing, kernel cache)")
    parser.add_argument("--threads", type=int, help="Dr.Jit threads (default: the config's fit.threads)")
    parser.add_argument("--variant", default="llvm_ad_rgb")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--name", default="render_split", help="report name (<out>/<name>.{csv,md})")
    args = parser.parse_args()
    config = validated_config()
    threads = args.threads or config["fit"]["threads"]
    rows = [row for image in args.images.split(",")
            for row in image_rows(args.run.resolve(), image, args.variant, threads, args.calls, args.warm_up, config)]
    normals = config["fit"]["normals"]
    settings = (f"{args.variant}, {threads} thread(s), {normals['resolution']} px, {normals['spp']} spp, "
                f"{normals['sampler']} sampler")
    table = pd.DataFrame(rows)
    publish(args.out, args.name, table, summary(table, settings), float_format="%.2f")


if __name__ == "__main__":
    main()
