"""What every fit stage shares: targets, the image loss, rendering and stage outputs."""
from __future__ import annotations

import csv
import io
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from clothscope.core.atomic import write_json, write_text, write_with
from clothscope.core.imageio import decode_exr, linear_to_srgb, read_png, write_png
from clothscope.fit.model import PREVIEW_SAMPLER, FitCamera, FitScene, Material, PointLight
from clothscope.prepare.image import CLIPPED_FILE, IMAGE_FILE, read_status, resize_channel

#: Files of a fit stage's output folder: its record, the mesh grid, the loss curve, and the normal-map stage's maps.
STATE_FILE = "state.json"
GRID_FILE = "grid.npy"
LOSS_FILE = "loss.csv"
NORMAL_FILE = "normal.exr"
HEIGHT_FILE = "height.exr"


class SkipStage(Exception):
    """The input of a stage was rejected upstream; the stage records a skip."""


@dataclass
class Target:
    """A photo at one resolution and its per-pixel weights (0 on clipped pixels)."""

    image: np.ndarray
    weight: np.ndarray
    cache: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def resolution(self) -> int:
        return int(self.image.shape[0])


def load_prepared(prepared_dir: str | os.PathLike[str]) -> Target:
    """The working image and clipped mask of a prepared image; SkipStage if it was rejected."""
    status = read_status(prepared_dir)
    if status.get("status") != "accepted":
        raise SkipStage(f"rejected by prepare: {status.get('reason', '')}")

    decoded = decode_exr(Path(prepared_dir) / IMAGE_FILE, 1, 1e9)
    clipped = read_png(Path(prepared_dir) / CLIPPED_FILE) > 0.5
    return Target(decoded.rgb.astype(np.float32), (~clipped).astype(np.float32))


def box_downsample(array: np.ndarray, size: int) -> np.ndarray:
    """Area-average an (H, W[, C]) array to size x size (exact block means when H is a multiple of size)."""
    height = array.shape[0]
    if height == size:
        return array.astype(np.float32)
    if height % size == 0:
        f = height // size
        shape = (size, f, size, f) + array.shape[2:]
        return array.reshape(shape).mean(axis=(1, 3)).astype(np.float32)
    if array.ndim == 2:
        return resize_channel(array, size)
    return np.stack([resize_channel(array[..., c], size) for c in range(array.shape[2])], axis=-1)


def at_resolution(target: Target, size: int) -> Target:
    """The target box-filtered to ``size`` px; a pixel counts only if no clipped pixel fell into it."""
    return Target(box_downsample(target.image, size), (box_downsample(target.weight, size) > 0.999).astype(np.float32))


def image_loss(mi: ModuleType, rendered: Any, target: Target) -> Any:
    """Weighted mean squared error, normalised by the target's mean square (so black cloth still has gradients)."""
    import drjit as dr

    if "loss" not in target.cache:  # device copies and constants made once per stage, not per iteration
        weight = np.repeat(target.weight[..., None], 3, axis=2)
        scale = 1.0 / ((float(weight.sum()) + 1.0) * (float(np.mean(target.image**2)) + 1e-6))
        target.cache["loss"] = (mi.TensorXf(target.image), mi.TensorXf(weight * scale))
    t, w = target.cache["loss"]
    return dr.sum((rendered - t) ** 2 * w, axis=None)


def render(mi: ModuleType, scene: Any, params: Any, spp: int, seed: int, spp_grad: int = 0) -> Any:
    """Render with a fresh seed per iteration (the primal and gradient noise decorrelate).

    ``spp`` samples per pixel go into the image the loss compares with the photo,
    ``spp_grad`` into the gradient pass (0: the same as ``spp``).
    """
    return mi.render(scene, params, spp=spp, spp_grad=spp_grad, seed=seed, seed_grad=seed + 100_003)


def psnr(rendered: np.ndarray, target: Target) -> float:
    """PSNR (dB) of the sRGB-encoded images over unclipped pixels, capped at 99 dB."""
    a = linear_to_srgb(np.clip(rendered, 0.0, 1.0))
    b = linear_to_srgb(np.clip(target.image, 0.0, 1.0))
    w = target.weight[..., None] * np.ones(3)
    mse = float(np.sum((a - b) ** 2 * w) / max(np.sum(w), 1.0))
    return float(min(99.0, 10 * np.log10(1.0 / max(mse, 1e-10))))


def sigmoid(x: Any) -> Any:
    import drjit as dr

    return 1.0 / (1.0 + dr.exp(-x))


def logit(p: np.ndarray | float) -> np.ndarray:
    p = np.clip(np.asarray(p, dtype=np.float32), 1e-4, 1 - 1e-4)
    return np.log(p / (1 - p)).astype(np.float32)


# --- stage outputs ---------------------------------------------------------------------------

def write_loss_curve(target: Path, curve: list[dict[str, float]]) -> None:
    """Loss curve CSV: iteration, loss, learning_rate, seconds (phase column when present)."""
    buffer = io.StringIO()
    fields = ["phase", "iteration", "loss", "learning_rate", "seconds"]
    writer = csv.DictWriter(buffer, fieldnames=fields, extrasaction="ignore")
    writer.writeheader()
    for row in curve:
        writer.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
    write_text(target, buffer.getvalue())


def write_comparison(target: Path, photo: Target, rendered: np.ndarray) -> None:
    """Side-by-side PNG: target | fit | absolute error (x4), sRGB."""
    size = photo.resolution
    fit = box_downsample(rendered, size) if rendered.shape[0] != size else rendered
    a, b = linear_to_srgb(np.clip(photo.image, 0, 1)), linear_to_srgb(np.clip(fit, 0, 1))
    error = np.clip(4 * np.abs(a - b), 0, 1)
    gap = np.ones((size, 4, 3), dtype=np.float32)
    write_png(target, np.concatenate([a, gap, b, gap, error], axis=1))


def save_state(out_dir: Path, fit: FitScene, record: dict[str, Any]) -> None:
    """Write the fit scene (grid as .npy, the rest as JSON) for the next stage."""
    write_with(out_dir / GRID_FILE, lambda tmp: np.save(tmp, fit.grid.astype(np.float32)))
    write_json(out_dir / STATE_FILE, record | {"status": "fitted", "scene": fit.to_record()})


def load_state(stage_dir: str | os.PathLike[str]) -> tuple[FitScene, dict[str, Any]]:
    """Read a stage's fit scene back; SkipStage when that stage was skipped."""
    stage_dir = Path(stage_dir)
    record = json.loads((stage_dir / STATE_FILE).read_text(encoding="utf-8"))
    if record.get("status") != "fitted":
        raise SkipStage(record.get("reason", "upstream stage skipped"))
    scene = record["scene"]
    fit = FitScene(
        camera=FitCamera(scene["camera"]["fov_deg"], scene["camera"]["distance"]),
        light=PointLight(scene["light"]["polar_deg"], scene["light"]["azimuth_deg"], scene["light"]["distance"],
                         scene["light"].get("incidence_deg")),
        grid=np.load(stage_dir / GRID_FILE).astype(np.float64),
        margin=scene["margin"],
        material=Material(tuple(scene["material"]["base_color"]), scene["material"]["specular"], scene["material"]["roughness"]),
    )
    return fit, record


def scene_xml(fit: FitScene, mesh_file: str, normal_file: str | None, resolution: int, spp: int = 64,
              albedo_file: str | None = None) -> str:
    """A Mitsuba 3 scene file that re-renders the fit (`mitsuba scene.xml`); ``albedo_file``: a base-colour texture."""
    m, light = fit.material, fit.light
    color = " ".join(f"{c:.6g}" for c in m.base_color)
    base = f'<rgb name="base_color" value="{color}"/>' if albedo_file is None else (
        f'<texture name="base_color" type="bitmap"><string name="filename" value="{albedo_file}"/>'
        f'<boolean name="raw" value="true"/></texture>')
    principled = (f'<bsdf type="principled">{base}'
                  f'<float name="specular" value="{m.specular:.6g}"/><float name="roughness" value="{m.roughness:.6g}"/></bsdf>')
    bsdf = principled if normal_file is None else (
        f'<bsdf type="normalmap"><texture name="normalmap" type="bitmap"><string name="filename" value="{normal_file}"/>'
        f'<boolean name="raw" value="true"/></texture>{principled}</bsdf>')
    px, py, pz = light.position
    return f"""<scene version="3.0.0">
    <!-- re-renders the clothscope fit: run `mitsuba scene.xml` in this folder -->
    <integrator type="direct"/>
    <sensor type="perspective">
        <float name="fov" value="{fit.camera.fov_deg:.6g}"/>
        <transform name="to_world"><lookat origin="0, 0, {fit.camera.distance:.6g}" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="{PREVIEW_SAMPLER}"><integer name="sample_count" value="{spp}"/></sampler>
        <film type="hdrfilm"><integer name="width" value="{resolution}"/><integer name="height" value="{resolution}"/>
            <rfilter type="box"/></film>
    </sensor>
    <emitter type="point">
        <point name="position" x="{px:.6g}" y="{py:.6g}" z="{pz:.6g}"/>
        <rgb name="intensity" value="{light.intensity:.6g}"/>
    </emitter>
    <shape type="ply">
        <string name="filename" value="{mesh_file}"/>
        {bsdf}
    </shape>
</scene>
"""
