"""A fit stage's output folder: its file names, its state record, loss curve, comparison figure and scene file.

Each stage (``geometry``, ``material``, ``normals``) writes one folder; the next
stage, the ``features`` rule and the accuracy benchmark read it through the
names and readers here.
"""
from __future__ import annotations

import csv
import io
import json
import os
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np

from clothscope.core.atomic import write_json, write_text, write_with
from clothscope.core.imageio import linear_to_srgb, write_png
from clothscope.fit.model import PREVIEW_SAMPLER, FitCamera, FitLight, FitScene, Material
from clothscope.fit.target import SkipStage, Target, box_downsample

#: The :class:`FitLight` fields a state's ``scene.light`` holds (older records lack the newer ones, which keep their defaults).
LIGHT_FIELDS = frozenset(field.name for field in fields(FitLight))
#: The stage's record (status, settings, fitted scene) and its mesh grid (read back by :func:`load_state`).
STATE_FILE = "state.json"
GRID_FILE = "grid.npy"
#: The loss curve (:func:`write_loss_curve`) and the photo | fit | error figure (:func:`write_comparison`).
LOSS_FILE = "loss.csv"
COMPARISON_FILE = "compare.png"
#: The fitted mesh and a Mitsuba scene that re-renders the fit (:func:`scene_xml`).
MESH_FILE = "mesh.ply"
SCENE_FILE = "scene.xml"
#: The fitted BSDF (material and normals stages).
MATERIAL_FILE = "material.json"
#: The normals stage's maps: unit normals (xyz), relief (three equal channels) and the normal map as a PNG.
NORMAL_FILE = "normal.exr"
HEIGHT_FILE = "height.exr"
NORMAL_PNG_FILE = "normal.png"
#: The fitted shade texture (three equal channels), when the colour model fits one.
SHADE_FILE = "shade.exr"
#: The soft light's environment map (linear RGB, latitude-longitude), which ``scene.xml`` reads when the fit chose one.
LIGHT_FILE = "light.exr"
#: The fitted base-colour texture (linear RGB: colour times shade times dye layout), which ``scene.xml`` reads.
ALBEDO_FILE = "albedo.exr"


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
        light=FitLight(**{key: value for key, value in scene["light"].items() if key in LIGHT_FIELDS}),
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
    emitter = (f'<emitter type="envmap"><string name="filename" value="{LIGHT_FILE}"/></emitter>' if light.spread_deg > 0 else
               f'<emitter type="point"><point name="position" x="{px:.6g}" y="{py:.6g}" z="{pz:.6g}"/>'
               f'<rgb name="intensity" value="{light.intensity:.6g}"/></emitter>')
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
    {emitter}
    <shape type="ply">
        <string name="filename" value="{mesh_file}"/>
        {bsdf}
    </shape>
</scene>
"""
