"""render_split.py: the integrators that stop after each part of the forward render, and the summary."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

from clothscope.core.runtime import mitsuba_for
from clothscope.fit.model import FitCamera, FitLight, FitScene, Material, build_scene, plane_grid

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
import render_split  # noqa: E402


def test_each_part_renders_finite_values_and_the_last_is_the_fits_render():
    mi = mitsuba_for("llvm_ad_rgb", 2)
    fit = FitScene(FitCamera(), FitLight(30.0, 60.0), plane_grid(FitCamera(), 8, 0.06), 0.06, Material((0.6, 0.3, 0.2), 0.5, 0.4))
    scene = build_scene(mi, fit, 16, {"type": "direct_unshadowed"}, "independent")
    images = {name: np.array(mi.render(scene, integrator=integrator, spp=2, seed=1))
              for name, integrator in render_split.part_integrators(mi).items()}
    assert list(images) == list(render_split.PARTS)
    assert all(np.isfinite(image).all() and image.shape == (16, 16, 3) for image in images.values())
    assert np.allclose(images[render_split.PARTS[-1]], np.array(mi.render(scene, spp=2, seed=1)))
    assert images["+ surface interaction"][..., 2].min() > 0.9  # the plane's shading normal faces the camera


def test_summary_adds_each_part_to_the_one_before():
    rows = [{"image": image, "part": part, "ms": ms} for image, times in (("a", (4, 20, 22, 35)), ("b", (4, 20, 24, 45)))
            for part, ms in zip(render_split.PARTS, times)]
    lines = render_split.summary(pd.DataFrame(rows), "test").splitlines()
    assert "| median | 4.0 | 20.0 | 23.0 | 40.0 |" in lines
    assert "| median share of the render | 10% | 40% | 8% | 42% |" in lines
