"""Benchmark: how low the fold normal error can go under the fit's camera and light model.

For every synthetic image (ground truth only, no fitting; seconds in all):

- ``flat_deg``: a flat plane seen by the true camera (what knowing nothing gives);
- ``light_only_deg``: the true fold normals with only their slope along the
  light's azimuth kept, the perpendicular slope set to zero, seen by the true
  camera. Shading from one light constrains the slope along its direction
  only, so a fit without a shape prior stronger than smoothness cannot beat this;
- ``untilted_camera_deg``: the exact true fold surface seen by the fit's
  untilted camera (the synthetic camera is tilted 0-10 deg; the fit's is not),
  scored like a fit (``clothscope.evaluate.accuracy.fold_normal_error``).

    .venv/bin/python workflow/benchmarks/fold_bounds.py

Writes ``results/reports/fold_bounds.{csv,md}``; compare with the fitted
``fold_normal_error_deg`` in ``results/reports/fit_accuracy.csv``.
"""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
from harness import ROOT, publish

from clothscope.core.config import schema_defaults
from clothscope.evaluate.accuracy import angular_error_deg, camera_basis, fold_normal_error, hit_plane, pixel_rays
from clothscope.fit.model import FitCamera, plane_grid
from clothscope.synth.generate import fold_surface

RESOLUTION = 64


def unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def true_camera_errors(truth: dict) -> tuple[float, float]:
    """Median error (deg) of a flat plane and of the along-light-only normals, in the true camera's view."""
    cam = truth["camera"]
    origin = np.array(cam["origin"])
    rays = pixel_rays(camera_basis(origin, np.array(cam["target"]), np.array(cam["up"])), cam["fov_deg"], RESOLUTION)
    height = 0.0
    for _ in range(3):
        p = hit_plane(origin, rays, height)
        height, dzdx, dzdy = fold_surface(p[..., 0], p[..., 1], truth["folds"])
    true = unit(np.stack([-dzdx, -dzdy, np.ones_like(dzdx)], axis=-1))
    light = np.array(truth["light"]["position"])
    along = unit(light[:2])
    slope = dzdx * along[0] + dzdy * along[1]
    light_only = unit(np.stack([-slope * along[0], -slope * along[1], np.ones_like(slope)], axis=-1))
    flat = np.zeros_like(true)
    flat[..., 2] = 1.0
    return float(np.median(angular_error_deg(true, flat))), float(np.median(angular_error_deg(true, light_only)))


def untilted_camera_error(truth: dict, camera: FitCamera, margin: float) -> float:
    """Fold normal error of the exact true fold surface on the fit's grid, seen by the fit's camera."""
    grid = plane_grid(camera, 64, margin)
    grid[..., 2] = fold_surface(grid[..., 0], grid[..., 1], truth["folds"])[0]
    return fold_normal_error(truth, grid, camera.fov_deg, camera.distance, RESOLUTION)


def main() -> int:
    geometry = schema_defaults()["fit"]["geometry"]
    camera = FitCamera(geometry["fov_deg"])
    rows = []
    for path in sorted((ROOT / "data" / "synthetic").glob("*/*.truth.json")):
        truth = json.loads(path.read_text(encoding="utf-8"))
        flat, light_only = true_camera_errors(truth)
        rows.append({"image_id": path.name.removesuffix(".truth.json"), "fabric_class": truth["fabric_class"],
                     "flat_deg": flat, "light_only_deg": light_only,
                     "untilted_camera_deg": untilted_camera_error(truth, camera, geometry["margin"])})
    table = pd.DataFrame(rows)
    medians = table[["flat_deg", "light_only_deg", "untilted_camera_deg"]].median()
    text = "\n".join(["# Fold normal error bounds (median over images, degrees)", "",
                      medians.round(2).to_frame("median").to_markdown(), "",
                      f"{len(table)} images; ground truth only (`workflow/benchmarks/fold_bounds.py`).", ""])
    publish(ROOT / "results" / "reports", "fold_bounds", table, text, "%.4g")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
