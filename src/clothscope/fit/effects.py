"""Effects plan: which light transport each fit stage simulates, and why.

The fit scene is one opaque cloth sheet lit by one point light. Its
light can reach the camera after one bounce; more bounces only matter where
the fitted cloth faces itself (deep folds). Visibility gradients (projective
integrators) only matter where vertices move and an outline or
self-occlusion is in view. Spectral and polarised rendering are never needed.
The plan is decided from evidence about the image and the fitted geometry and
written into every output's metadata.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from .model import FitCamera


@dataclass(frozen=True)
class Evidence:
    """What the planner knows about a scene."""

    outline_in_view: bool = False  # the plane always overhangs the view in our camera model
    self_occlusion: bool = False  # some fitted surface hides another from the camera
    facing_folds: bool = False  # fitted surface patches face each other (inter-reflection)


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
        if self.integrator == "direct":
            return {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0}
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
    if stage not in ("geometry", "material", "normals"):
        raise ValueError(f"unknown fit stage {stage!r}")
    if full_effects:
        return Plan(stage, "prb_projective", full_depth, True, ("forced full-effects baseline (fit.full_effects)",))
    moves_vertices = stage == "geometry"
    needs_visibility = moves_vertices and (evidence.outline_in_view or evidence.self_occlusion)
    needs_bounces = evidence.facing_folds
    reasons = ["one opaque sheet and one point light: light reaches the camera after one bounce"]
    if needs_bounces:
        reasons = ["fitted folds face each other: inter-reflection needs 3 bounces"]
    if needs_visibility:
        reasons.append("vertices move and an outline or self-occlusion is in view: visibility gradients")
    elif moves_vertices:
        reasons.append("no outline or self-occlusion in view: no visibility gradients")
    else:
        reasons.append("geometry fixed in this stage: no visibility gradients")
    reasons.append("no dispersion or polarisation in the model: RGB, unpolarised")
    if needs_bounces:
        integrator = "prb_projective" if needs_visibility else "prb"
        return Plan(stage, integrator, 3, needs_visibility, tuple(reasons))
    return Plan(stage, "direct_projective" if needs_visibility else "direct", 1, needs_visibility, tuple(reasons))


def geometry_evidence(grid: np.ndarray, camera: FitCamera, facing_cos: float = 0.5) -> Evidence:
    """Evidence from a fitted (n, n, 3) grid: self-occlusion and facing folds.

    Self-occlusion: some vertex normal turns away from the camera ray (the
    surface folds over). Facing folds: two surface patches within a fold width
    whose normals point toward each other at more than ``facing_cos``.
    """
    from ..synth.scene import grid_normals

    normals = grid_normals(grid)
    to_camera = np.array([0.0, 0.0, camera.distance]) - grid
    to_camera /= np.linalg.norm(to_camera, axis=-1, keepdims=True)
    self_occlusion = bool(np.any(np.sum(normals * to_camera, axis=-1) <= 0.05))
    tilt = np.degrees(np.arccos(np.clip(normals[..., 2], -1.0, 1.0)))
    # a valley whose walls tilt toward each other by more than ~60 deg in total bounces light between them
    facing = bool(tilt.max() > np.degrees(np.arccos(facing_cos)))
    return Evidence(outline_in_view=False, self_occlusion=self_occlusion, facing_folds=facing)
