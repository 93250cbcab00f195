"""Effects plan: which light transport each fit stage simulates, and why.

The fit scene is one opaque cloth sheet lit by one light (a point, or a
distant soft disc). Its light can reach the camera after one bounce; more
bounces only matter where the fitted cloth faces itself (deep folds). Shadow rays only matter where the
fitted surface can shadow itself from the light; elsewhere the planner picks
``direct_unshadowed`` (:mod:`.integrator`). Visibility gradients (projective
integrators) only matter where vertices move and an outline or
self-occlusion is in view. Spectral and polarised rendering are never needed.
The plan is decided from evidence about the image and the fitted geometry and
written into every output's metadata.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from scipy import ndimage

from clothscope.core.config import FIT_STAGES
from clothscope.core.mesh import grid_normals
from clothscope.fit.integrator import NAME as UNSHADOWED
from clothscope.fit.model import FitCamera, FitLight


@dataclass(frozen=True)
class Evidence:
    """What the planner knows about a scene."""

    outline_in_view: bool = False  # the plane always overhangs the view in our camera model
    self_occlusion: bool = False  # some fitted surface hides another from the camera
    facing_folds: bool = False  # fitted surface patches face each other (inter-reflection)
    cast_shadows: bool = False  # some fitted surface hides the light from another (a flat sheet never does)


@dataclass(frozen=True)
class Plan:
    """Integrator and options of one stage."""

    stage: str
    integrator: str
    max_depth: int
    projective: bool
    reasons: tuple[str, ...]
    spectral: bool = False
    polarized: bool = False

    def integrator_dict(self) -> dict[str, Any]:
        """The Mitsuba integrator description of this plan."""
        if self.integrator == "direct":  # a BSDF sample can never hit a point light
            return {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0}
        if self.integrator == UNSHADOWED:
            return {"type": UNSHADOWED}
        if self.integrator == "direct_projective":
            return {"type": "direct_projective"}
        if self.integrator == "prb_projective":
            # the octree guiding of indirect silhouettes is rebuilt in Python every iteration and
            # dominates on CPU (minutes per stage at 64 px); unguided sampling keeps the same estimator
            return {"type": "prb_projective", "max_depth": self.max_depth, "guiding": "none"}
        return {"type": self.integrator, "max_depth": self.max_depth}

    def as_record(self) -> dict[str, Any]:
        return asdict(self) | {"reasons": list(self.reasons)}


def plan_stage(stage: str, evidence: Evidence, full_effects: bool = False, full_depth: int = 8) -> Plan:
    """Pick the cheapest integrator that simulates what ``stage`` of this scene needs.

    Parameters
    ----------
    stage : "geometry", "material" or "normals".
    evidence : what is known about the scene.
    full_effects : force the baseline (path tracing with projective gradients, many bounces).
    """
    if stage not in FIT_STAGES:
        raise ValueError(f"unknown fit stage {stage!r}")
    if full_effects:
        return Plan(stage, "prb_projective", full_depth, True, ("forced full-effects baseline (fit.full_effects)",))
    moves_vertices = stage == "geometry"
    needs_visibility = moves_vertices and (evidence.outline_in_view or evidence.self_occlusion)
    needs_bounces = evidence.facing_folds
    reasons = ["one opaque sheet and one light: light reaches the camera after one bounce"]
    if needs_bounces:
        reasons = ["fitted folds face each other: inter-reflection needs 3 bounces"]
    if needs_visibility:
        reasons.append("vertices move and an outline or self-occlusion is in view: visibility gradients")
    elif moves_vertices:
        reasons.append("no outline or self-occlusion in view: no visibility gradients")
    else:
        reasons.append("geometry fixed in this stage: no visibility gradients")
    if not needs_bounces and not needs_visibility:
        reasons.append("the fitted surface can shadow itself: shadow rays" if evidence.cast_shadows
                       else "no surface can shadow another from the light: no shadow rays")
    reasons.append("no dispersion or polarisation in the model: RGB, unpolarised")
    if needs_bounces:
        integrator = "prb_projective" if needs_visibility else "prb"
        return Plan(stage, integrator, 3, needs_visibility, tuple(reasons))
    if needs_visibility:
        return Plan(stage, "direct_projective", 1, True, tuple(reasons))
    return Plan(stage, "direct" if evidence.cast_shadows else UNSHADOWED, 1, False, tuple(reasons))


def casts_shadows(grid: np.ndarray, light: FitLight, clearance: float = 1e-4) -> bool:
    """True when some vertex of the (n, n, 3) height-field grid cannot see ``light``.

    Marches from every vertex toward the light in steps of half a grid cell
    and tests the bilinear height of the grid under each step; the march ends
    once the ray rises above the highest vertex or leaves the grid.
    """
    n = grid.shape[0]
    lo, hi = grid[0, 0, :2], grid[-1, -1, :2]
    cell = float(hi[0] - lo[0]) / (n - 1)
    points = grid.reshape(-1, 3)
    to_light = np.asarray(light.position) - points
    to_light /= np.linalg.norm(to_light, axis=1, keepdims=True)
    if np.any(to_light[:, 2] <= 0):
        return True  # the light is at or below some vertex's horizon
    top = float(grid[..., 2].max())
    reach = float(np.max((top - points[:, 2]) / to_light[:, 2]))
    for t in np.arange(0.5 * cell, reach + cell, 0.5 * cell):
        p = points + t * to_light
        inside = (p[:, 0] >= lo[0]) & (p[:, 0] <= hi[0]) & (p[:, 1] >= lo[1]) & (p[:, 1] <= hi[1]) & (p[:, 2] <= top)
        if not inside.any():
            break
        cols, rows = (p[inside, 0] - lo[0]) / cell, (p[inside, 1] - lo[1]) / cell
        surface = ndimage.map_coordinates(grid[..., 2], [rows, cols], order=1, mode="nearest")
        if np.any(surface > p[inside, 2] + clearance):
            return True
    return False


def geometry_evidence(grid: np.ndarray, camera: FitCamera, light: FitLight | None = None,
                      facing_cos: float = 0.5) -> Evidence:
    """Evidence from a fitted (n, n, 3) grid: self-occlusion, facing folds and cast shadows.

    Self-occlusion: some vertex normal turns away from the camera ray (the
    surface folds over). Facing folds: two surface patches within a fold width
    whose normals point toward each other at more than ``facing_cos``. Cast
    shadows: :func:`casts_shadows` (assumed when the light is unknown).
    """

    normals = grid_normals(grid)
    to_camera = np.array([0.0, 0.0, camera.distance]) - grid
    to_camera /= np.linalg.norm(to_camera, axis=-1, keepdims=True)
    self_occlusion = bool(np.any(np.sum(normals * to_camera, axis=-1) <= 0.05))
    tilt = np.degrees(np.arccos(np.clip(normals[..., 2], -1.0, 1.0)))
    # a valley whose walls tilt toward each other by more than ~60 deg in total bounces light between them
    facing = bool(tilt.max() > np.degrees(np.arccos(facing_cos)))
    shadows = True if light is None else casts_shadows(grid, light)
    return Evidence(outline_in_view=False, self_occlusion=self_occlusion, facing_folds=facing, cast_shadows=shadows)
