"""Errors of a fit against the ground truth of a synthetic image.

Geometry is compared registration-free, in view space: every pixel's ray is
intersected with the true cloth (through the true camera) and with the fitted
mesh (through the fit camera), and the two surface normals, each expressed in
its own camera's frame, are compared. Material errors are absolute; the thread
period is compared through the spectra of the fitted and true normal maps.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from scipy import ndimage

from .synth.generate import fold_surface


def camera_basis(origin: np.ndarray, target: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Rows: left, up, forward of Mitsuba's ``look_at`` frame."""
    forward = (target - origin) / np.linalg.norm(target - origin)
    left = np.cross(up, forward)
    left /= np.linalg.norm(left)
    return np.stack([left, np.cross(forward, left), forward])


def pixel_rays(basis: np.ndarray, fov_deg: float, resolution: int) -> np.ndarray:
    """(R, R, 3) unit world directions through pixel centres (row 0 at the image top)."""
    s = (np.arange(resolution) + 0.5) / resolution * 2 - 1
    sx, sy = np.meshgrid(s, s)
    t = np.tan(np.deg2rad(fov_deg) / 2)
    local = np.stack([-sx * t, -sy * t, np.ones_like(sx)], axis=-1)
    world = local @ basis
    return world / np.linalg.norm(world, axis=-1, keepdims=True)


def hit_plane(origin: np.ndarray, rays: np.ndarray, height: float | np.ndarray = 0.0) -> np.ndarray:
    """Points where rays from ``origin`` reach z = ``height``."""
    t = (height - origin[2]) / rays[..., 2]
    return origin + t[..., None] * rays


def truth_view_normals(truth: dict[str, Any], resolution: int) -> np.ndarray:
    """(R, R, 3) true fold normals in the true camera's frame."""
    cam = truth["camera"]
    origin, basis = np.array(cam["origin"]), camera_basis(np.array(cam["origin"]), np.array(cam["target"]), np.array(cam["up"]))
    rays = pixel_rays(basis, cam["fov_deg"], resolution)
    height = 0.0
    for _ in range(3):  # fixed point: the fold surface is a height field close to z = 0
        p = hit_plane(origin, rays, height)
        height, dzdx, dzdy = fold_surface(p[..., 0], p[..., 1], truth["folds"])
    normal = np.stack([-dzdx, -dzdy, np.ones_like(dzdx)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return normal @ basis.T


def fit_view_normals(grid: np.ndarray, fov_deg: float, distance: float, resolution: int) -> np.ndarray:
    """(R, R, 3) normals of a fitted (n, n, 3) grid (rows along +y) in the fit camera's frame."""
    from .synth.scene import grid_normals

    origin = np.array([0.0, 0.0, distance])
    basis = camera_basis(origin, np.zeros(3), np.array([0.0, 1.0, 0.0]))
    rays = pixel_rays(basis, fov_deg, resolution)
    normals = grid_normals(grid)
    lo, hi, n = grid[0, 0, :2], grid[-1, -1, :2], grid.shape[0]
    height = np.zeros(rays.shape[:2])
    for _ in range(3):
        p = hit_plane(origin, rays, height)
        cols = (p[..., 0] - lo[0]) / (hi[0] - lo[0]) * (n - 1)
        rows = (p[..., 1] - lo[1]) / (hi[1] - lo[1]) * (n - 1)
        height = ndimage.map_coordinates(grid[..., 2], [rows, cols], order=1, mode="nearest")
    view = np.stack([ndimage.map_coordinates(normals[..., k], [rows, cols], order=1, mode="nearest") for k in range(3)], -1)
    view /= np.linalg.norm(view, axis=-1, keepdims=True)
    return view @ basis.T


def angular_error_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per-pixel angle between unit vectors, degrees."""
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=-1), -1.0, 1.0)))


def fold_normal_error(truth: dict[str, Any], grid: np.ndarray, fov_deg: float, distance: float, resolution: int = 64) -> float:
    """Median view-space angle (deg) between the true fold normals and the fitted mesh normals."""
    error = angular_error_deg(truth_view_normals(truth, resolution), fit_view_normals(grid, fov_deg, distance, resolution))
    return float(np.median(error))
