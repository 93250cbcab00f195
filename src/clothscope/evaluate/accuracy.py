"""Errors of a fit against the ground truth of a synthetic image.

Geometry is compared registration-free, in view space: every pixel's ray is
intersected with the true cloth (through the true camera) and with the fitted
mesh (through the fit camera), and the two surface normals, each expressed in
its own camera's frame, are compared. Material errors are absolute; the thread
period is compared through the spectra of the fitted and true normal maps, and,
as the scale the whole pipeline works at, the period ``prepare`` read on the photo.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from scipy import ndimage

from clothscope.core.atomic import write_text
from clothscope.core.config import FIT_STAGES, settings
from clothscope.core.imageio import read_exr
from clothscope.core.mesh import grid_normals
from clothscope.core.truth import truth_paths
from clothscope.features.period import thread_period
from clothscope.features.sources import prepared_period
from clothscope.fit.model import plane_grid
from clothscope.fit.outputs import NORMAL_FILE, STATE_FILE, load_state
from clothscope.prepare.image import STATUS_FILE
from clothscope.synth.generate import fold_surface


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


def truth_surface(truth: dict[str, Any], resolution: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where each pixel's ray meets the true fold surface: points, slopes dz/dx and dz/dy, and the camera basis."""
    cam = truth["camera"]
    origin, basis = np.array(cam["origin"]), camera_basis(np.array(cam["origin"]), np.array(cam["target"]), np.array(cam["up"]))
    rays = pixel_rays(basis, cam["fov_deg"], resolution)
    height = 0.0
    for _ in range(3):  # fixed point: the fold surface is a height field close to z = 0
        p = hit_plane(origin, rays, height)
        height, dzdx, dzdy = fold_surface(p[..., 0], p[..., 1], truth["folds"])
    return hit_plane(origin, rays, height), dzdx, dzdy, basis


def truth_view_normals(truth: dict[str, Any], resolution: int) -> np.ndarray:
    """(R, R, 3) true fold normals in the true camera's frame."""
    _, dzdx, dzdy, basis = truth_surface(truth, resolution)
    normal = np.stack([-dzdx, -dzdy, np.ones_like(dzdx)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return normal @ basis.T


def fit_view_normals(grid: np.ndarray, fov_deg: float, distance: float, resolution: int) -> np.ndarray:
    """(R, R, 3) normals of a fitted (n, n, 3) grid (rows along +y) in the fit camera's frame."""
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


def plane_normal(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Unit normal (z component positive) of the least-squares plane through points (x, y, z)."""
    design = np.stack([np.ones(x.size), x.ravel(), y.ravel()], axis=1)
    _, a, b = np.linalg.lstsq(design, z.ravel(), rcond=None)[0]
    return np.array([-a, -b, 1.0]) / np.sqrt(1.0 + a * a + b * b)


def tilt_error_deg(truth: dict[str, Any], grid: np.ndarray, resolution: int = 64) -> float:
    """Angle (deg) between the best-fit planes of the true cloth in view and of the fitted grid.

    Both in the camera's frame: the true surface seen through the true camera
    is expressed like the fit's (x to the image right, y up, z toward the camera).
    """
    points, _, _, basis = truth_surface(truth, resolution)
    view = (points - np.array(truth["camera"]["origin"])) @ basis.T  # left, up, forward
    true_normal = plane_normal(-view[..., 0], view[..., 1], -view[..., 2])
    fitted_normal = plane_normal(grid[..., 0], grid[..., 1], grid[..., 2])
    return float(angular_error_deg(true_normal, fitted_normal))


def seen_scale(truth: dict[str, Any], resolution: int = 64) -> float:
    """Mean magnification of the visible cloth relative to the plane z = 0 the nominal period is given at.

    The folds lift or lower the cloth by up to about 0.1 at a camera distance of 3,
    so the threads in view look up to about 5% larger or smaller than the nominal
    ``thread_period_px``. One photo cannot know its absolute depth; what it can
    measure is the period at the depth the cloth is seen at: nominal times this scale.
    """
    points, _, _, basis = truth_surface(truth, resolution)
    origin = np.array(truth["camera"]["origin"])
    depth = (points - origin) @ basis[2]
    return float(np.mean(np.linalg.norm(origin - np.array(truth["camera"]["target"])) / depth))


def window_seen_scale(truth: dict[str, Any], window_px: int) -> float:
    """:func:`seen_scale` over the centred ``window_px`` square of the native frame (the whole frame when larger).

    A period read on a centred window sees the cloth at the window's depth, not
    at the whole frame's: close up, folds change the magnification across the frame.
    """
    side = int(truth.get("image_resolution") or truth["camera"]["resolution"])
    return seen_scale(in_working_frame(truth, {"crop_px": min(int(window_px), side)}, side))


def period_error(fitted_period_px: float | None, truth: dict[str, Any], scale: float = 1.0) -> float | None:
    """Relative error of a fitted thread period against the true one (knits: wale or course, the closer).

    ``scale`` multiplies the true periods (:func:`seen_scale` gives the period as
    seen in the photo). None when the cloth has no period (velvet); 1.0 when a
    period exists but none was found.
    """
    periods = [p * scale for p in (truth.get("thread_period_px"), truth.get("course_period_px")) if p]
    if not periods:
        return None
    if not fitted_period_px:
        return 1.0
    return float(min(abs(fitted_period_px - p) / p for p in periods))


def fitted_period_px(normals: np.ndarray, texels_per_pixel: float, weighted: bool = True) -> float | None:
    """Thread period (image px) from the spectrum of a fitted normal map (:func:`clothscope.features.period.thread_period`)."""
    period = thread_period(normals, settings("features"), weighted)  # the schema's default spectrum settings
    return None if period is None else float(period / texels_per_pixel)


def benchmark_seconds(path: str | os.PathLike[str]) -> tuple[float, float] | None:
    """(wall seconds, peak RSS MB) from a Snakemake ``benchmark:`` file; None when it is absent (the job was not timed)."""
    if not Path(path).exists():
        return None
    row = pd.read_csv(path, sep="\t").iloc[-1]
    rss = pd.to_numeric(row.get("max_rss", 0.0), errors="coerce")
    return float(row["s"]), float(0.0 if not np.isfinite(rss) else rss)


def in_working_frame(truth: dict[str, Any], scale: dict[str, Any] | None, source_px: int) -> dict[str, Any]:
    """The truth record as the fit saw it: ``prepare``'s centred crop and downscaling undone.

    ``scale`` is the prepared status's ``scale`` record (``crop_px``,
    ``native_px_per_working_px``) of a square-cropped photo whose short side is
    ``source_px``. A centred crop narrows the camera's field of view, and the
    thread periods, given in native pixels, shrink by the downscaling factor.
    Without a record (or an uncropped, unscaled photo) the truth is returned as it is.
    """
    if not scale or source_px <= 0:
        return truth
    fraction = float(scale.get("crop_px", source_px)) / float(source_px)
    factor = float(scale.get("native_px_per_working_px", 1.0))
    if fraction == 1.0 and factor == 1.0:
        return truth
    camera = dict(truth["camera"])
    camera["fov_deg"] = float(np.degrees(2.0 * np.arctan(fraction * np.tan(np.deg2rad(camera["fov_deg"]) / 2.0))))
    periods = {key: truth[key] / factor for key in ("thread_period_px", "course_period_px") if truth.get(key)}
    return truth | {"camera": camera} | periods


def truth_as_fitted(truth_json: str | os.PathLike[str], prepared_status: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """An image's truth record, put in the frame the fit saw by its prepared ``status.json`` (:func:`in_working_frame`)."""
    truth = json.loads(Path(truth_json).read_text(encoding="utf-8"))
    if prepared_status is None:
        return truth
    status = json.loads(Path(prepared_status).read_text(encoding="utf-8"))
    return in_working_frame(truth, status.get("scale"), min(status.get("source_size") or [0]))


def stage_costs(benchmarks: dict[str, str]) -> dict[str, float | None]:
    """Each stage's ``<stage>_s`` and ``<stage>_max_rss_mb``, their ``total_s`` and ``max_rss_mb``.

    A stage without a benchmark file was not timed: its values are None (an empty
    cell, never a 0 that would pass a time target), and so are the total and the peak.
    """
    timings = {stage: benchmark_seconds(path) for stage, path in benchmarks.items()}
    row: dict[str, float | None] = {}
    for stage, timing in timings.items():
        row[f"{stage}_s"], row[f"{stage}_max_rss_mb"] = timing or (None, None)
    measured = [timing for timing in timings.values() if timing is not None]
    timed = len(measured) == len(timings)
    row["total_s"] = sum(seconds for seconds, _ in measured) if timed else None
    row["max_rss_mb"] = max((rss for _, rss in measured), default=0.0) if timed else None
    return row


def evaluate_fit(image_id: str, fit_root: str | os.PathLike[str], truth_json: str | os.PathLike[str],
                 benchmarks: dict[str, str], prepared_status: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """Every error of one image's fit against its ground truth, plus stage times and memory.

    ``prepared_status``: the image's prepared ``status.json``; its crop and scale
    put the truth in the frame the fit saw (:func:`in_working_frame`).
    """

    truth = truth_as_fitted(truth_json, prepared_status)
    row: dict[str, Any] = {"image_id": image_id, "fabric_class": truth["fabric_class"]}
    normals_dir = Path(fit_root) / "normals"
    state = json.loads((normals_dir / STATE_FILE).read_text(encoding="utf-8"))
    row["status"] = state["status"]
    row |= stage_costs(benchmarks)
    if state["status"] != "fitted":
        return row | {"reason": state.get("reason", "")}
    fit, _ = load_state(normals_dir)
    material = fit.material

    normals = read_exr(normals_dir / NORMAL_FILE)
    period = fitted_period_px(normals, state["texels_per_pixel"])
    row.update(
        psnr_db=state["psnr_db"],
        fold_normal_error_deg=fold_normal_error(truth, fit.grid, fit.camera.fov_deg, fit.camera.distance),
        flat_fold_normal_error_deg=fold_normal_error(truth, plane_grid(fit.camera, fit.grid.shape[0], fit.margin),
                                                     fit.camera.fov_deg, fit.camera.distance),
        tilt_error_deg=tilt_error_deg(truth, fit.grid),
        flat_tilt_error_deg=tilt_error_deg(truth, plane_grid(fit.camera, fit.grid.shape[0], fit.margin)),
        roughness=material.roughness, roughness_true=truth["roughness"],
        roughness_error=abs(material.roughness - truth["roughness"]),
        specular=material.specular, specular_true=truth["specular"],
        base_color_error=float(np.mean(np.abs(np.array(material.base_color) - np.array(truth["base_color_linear"])))),
        period_px=period if period is not None else 0.0,
        period_true_px=truth.get("thread_period_px") or 0.0,
        period_seen_scale=seen_scale(truth),
        effects=";".join(sorted({p["integrator"] for p in state.get("effects", [])})),
        warnings=len(state.get("warnings", [])),
    )
    error, nominal = period_error(period, truth, row["period_seen_scale"]), period_error(period, truth)
    row["period_error"] = -1.0 if error is None else error  # -1: no period to measure (pile); vs the seen period
    row["period_error_nominal"] = -1.0 if nominal is None else nominal  # vs thread_period_px at z = 0
    if prepared_status is not None:
        read = prepared_period(Path(prepared_status).parent)  # working px, as the truth is here
        prepare_error = period_error(read, truth, row["period_seen_scale"])
        row["prepare_period_px"] = read or 0.0
        row["prepare_period_error"] = -1.0 if prepare_error is None else prepare_error  # 1.0: no lattice found
    return row


#: issue targets: (column, statistic, comparison, bound)
TARGETS = (
    ("psnr_db", "median", ">=", 30.0),
    ("fold_normal_error_deg", "median", "<=", 7.0),
    ("roughness_error", "median", "<=", 0.05),
    ("base_color_error", "median", "<=", 0.05),
    ("total_s", "median", "<=", 30.0),
    ("max_rss_mb", "max", "<=", 2048.0),
)

#: medians reported beside the targets: the flat plane's fold error, the fit's and the level plane's tilt error
REFERENCE_ERRORS = ("flat_fold_normal_error_deg", "tilt_error_deg", "flat_tilt_error_deg")


def target_line(fitted: Any, column: str, stat: str, op: str, bound: float) -> str:
    """One Markdown row of a target: its statistic over the rows that hold a value, or "not measured".

    Rows whose value is missing (a stage that was not timed) are left out and counted
    in the row, so a missing time never reads as a met target.
    """
    values = pd.to_numeric(fitted[column], errors="coerce").dropna() if column in fitted else pd.Series(dtype=float)
    if values.empty:
        return f"| {column} | {stat} | not measured | {op} {bound:g} | not measured |"
    value = float(getattr(values, stat)())
    met = value >= bound if op == ">=" else value <= bound
    missing = len(fitted) - len(values)
    shown = f"{value:.3f}" + (f" ({len(values)} of {len(fitted)} measured)" if missing else "")
    return f"| {column} | {stat} | {shown} | {op} {bound:g} | {'yes' if met else 'no'} |"


def summarise(table: Any) -> str:
    """Markdown summary: medians against targets, the period hit rate, and per-class medians."""
    fitted = table[table["status"] == "fitted"]
    lines = ["# Inverse renderer accuracy on the synthetic set", "",
             f"{len(fitted)} of {len(table)} images fitted.", "", "| metric | statistic | value | target | met |", "|---|---|---|---|---|"]
    for column, stat, op, bound in TARGETS:
        lines.append(target_line(fitted, column, stat, op, bound))
    for column in REFERENCE_ERRORS:
        if column in fitted and len(fitted):
            lines.append(f"| {column} | median | {float(fitted[column].median()):.3f} | (for reference) | |")
    periodic = fitted[fitted["period_error"] >= 0]
    if len(periodic):
        hit = float((periodic["period_error"] <= 0.05).mean())
        lines.append(f"| period within 5% | fraction of {len(periodic)} periodic | {hit:.3f} | >= 0.9 | {'yes' if hit >= 0.9 else 'no'} |")
        if "period_error_nominal" in periodic:
            nominal = float((periodic["period_error_nominal"] <= 0.05).mean())
            lines.append(f"| period within 5% of the nominal z = 0 period | fraction of {len(periodic)} periodic | {nominal:.3f} | (for reference) | |")
        if "prepare_period_error" in periodic:
            read = float((periodic["prepare_period_error"] <= 0.05).mean())
            lines.append(f"| period read by `prepare` (native resolution) within 5% | fraction of {len(periodic)} periodic | "
                         f"{read:.3f} | (for reference) | |")
    lines += ["", "## Medians per class", "", fitted.groupby("fabric_class")[
        ["psnr_db", "fold_normal_error_deg", "flat_fold_normal_error_deg", "tilt_error_deg",
         "flat_tilt_error_deg", "roughness", "roughness_true", "roughness_error", "base_color_error", "period_error", "total_s"]
    ].median().round(3).to_markdown() if len(fitted) else "(none)", "",
              "`roughness` is the fitted roughness and `roughness_true` the generator's; where two classes' fitted "
              "values meet although their true ones do not, the fitted BRDF cannot tell them apart.", ""]
    if "period_seen_scale" in fitted and len(periodic):
        lo, hi = float(periodic["period_seen_scale"].min()), float(periodic["period_seen_scale"].max())
        lines += ["The period is compared with the true period as seen in the photo: the nominal `thread_period_px` "
                  "(threads on the plane z = 0) times the mean magnification of the visible folded cloth "
                  f"(`period_seen_scale`, {lo:.3f} to {hi:.3f} here), since one photo cannot know the cloth's absolute depth.", ""]
        if "prepare_period_error" in periodic:
            lines += ["The period read by `prepare` is the one it measured on the photo at native resolution to choose the crop "
                      "(`scale.working_period_px` of the prepared status, in working pixels; a photo without a lattice counts as a miss): "
                      "the scale the crop and the descriptor of a larger photo are made at.", ""]
    return "\n".join(lines)


#: errors the effects ablation compares (lower is better)
ABLATION_ERRORS = ("fold_normal_error_deg", "roughness_error", "base_color_error", "period_error")


def effects_comparison(table: Any, column: str, planned: str, full: str) -> str:
    """Markdown: median errors and time of the ``planned`` rows against the ``full``-effects rows.

    ``table`` holds ``fit_accuracy`` rows of both runs on the same images; ``column``
    names the run. The checks are those of the inverse-renderer issue: every error
    within 5% of the full-effects fit's, at no more than a quarter of its time.
    """
    both = table[table[column].isin([planned, full])]
    med = both.groupby(column)[["psnr_db", *ABLATION_ERRORS, "total_s", "max_rss_mb"]].median()
    med["period_error"] = both[both["period_error"] >= 0].groupby(column)["period_error"].median()
    p, f = med.loc[planned], med.loc[full]
    lines = [med.round(4).to_markdown(), "", "| check | planned | full | ratio | met |", "|---|---|---|---|---|",
             f"| PSNR within 5% | {p['psnr_db']:.2f} | {f['psnr_db']:.2f} | {p['psnr_db'] / f['psnr_db']:.3f} | "
             f"{'yes' if p['psnr_db'] >= 0.95 * f['psnr_db'] else 'no'} |"]
    for error in ABLATION_ERRORS:
        ratio = p[error] / f[error] if f[error] else float("inf")
        lines.append(f"| {error} within 5% | {p[error]:.4f} | {f[error]:.4f} | {ratio:.3f} | "
                     f"{'yes' if p[error] <= 1.05 * f[error] + 1e-9 else 'no'} |")
    time_ratio = p["total_s"] / f["total_s"]
    lines.append(f"| time <= 1/4 | {p['total_s']:.1f} s | {f['total_s']:.1f} s | {time_ratio:.3f} | "
                 f"{'yes' if time_ratio <= 0.25 else 'no'} |")
    return "\n".join(lines) + "\n"


def write_accuracy_report(photos: dict[str, str], normals_dirs: list[str], prepared_dirs: list[str], benchmark_root: str,
                          table: str, summary: str) -> int:
    """The ``fit_accuracy`` rule: every image's fit against the ground truth beside its photo.

    ``photos`` maps image id to photo path, in the order of ``normals_dirs`` (each
    image's ``normals`` stage folder) and ``prepared_dirs``. Writes the CSV table
    and the Markdown summary atomically and returns the number of images.
    """
    rows = []
    for (image, photo), normals_dir, prepared_dir in zip(photos.items(), normals_dirs, prepared_dirs, strict=True):
        benchmarks = {s: os.path.join(benchmark_root, f"fit_{s}", f"{image}.tsv") for s in FIT_STAGES}
        rows.append(evaluate_fit(image, Path(normals_dir).parent, truth_paths(Path(photo))["json"], benchmarks,
                                 Path(prepared_dir) / STATUS_FILE))
    frame = pd.DataFrame(rows)
    write_text(table, frame.to_csv(index=False, float_format="%.6g"))
    write_text(summary, summarise(frame))
    return len(rows)
