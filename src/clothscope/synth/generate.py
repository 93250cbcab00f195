"""Draw, render and save one synthetic fabric photo with its ground truth.

Everything is a deterministic function of ``(seed, class, colour index)``.
Ground-truth maps cover the square of cloth ``[-W/2, W/2]^2`` that the camera
centres on (``W`` = view width at the cloth), at the image resolution, with
row 0 at +y so they overlay the image; the thread period in map texels
therefore equals the period in image pixels at the image centre.
"""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy import ndimage

from clothscope.core.atomic import write_json, write_with
from clothscope.core.imageio import linear_to_srgb, write_png
from clothscope.core.mesh import cloth_mesh
from clothscope.core.runtime import mitsuba_for, runtime_metadata
from clothscope.core.truth import encode_normal, truth_paths
from clothscope.synth.fabrics import BASKET, FABRICS, PLAIN, SATIN5, FabricSpec, knit_height, pile_height, woven_height
from clothscope.synth.scene import Camera, Light, cloth_bsdf, effects_for, render, scene_dict

#: Six dyes (linear RGB), shared by every class.
DYES: dict[str, tuple[float, float, float]] = {
    "red": (0.55, 0.05, 0.05),
    "navy": (0.03, 0.05, 0.30),
    "green": (0.08, 0.32, 0.10),
    "mustard": (0.65, 0.42, 0.06),
    "ivory": (0.75, 0.73, 0.66),
    "charcoal": (0.035, 0.035, 0.04),
}
PATTERNS = {"plain": PLAIN, "basket": BASKET, "satin5": SATIN5}
CLOTH_HALF = 1.0  # the cloth mesh spans [-1, 1]^2
CAMERA_DISTANCE = 3.0
FOLD_GRID = 64  # fold displacement is saved on the 64 x 64 grid the fitter uses
TRUTH_VERSION = 1


@dataclass(frozen=True)
class Draw:
    """The random choices behind one image."""

    view_width: float
    period_px: float
    rotation_deg: float
    offset: tuple[float, float]
    folds: list[dict[str, float]]
    tilt_deg: float
    tilt_axis_deg: float
    light_polar_deg: float
    light_azimuth_deg: float
    light_distance: float
    exposure: float
    color: tuple[float, float, float]
    roughness: float
    specular: float
    backdrop: tuple[float, float, float] | None
    noise_gain: float
    noise_floor: float


def image_rng(seed: int, fabric: str, dye_index: int) -> np.random.Generator:
    """Independent, reproducible stream per (seed, class, dye)."""
    class_index = list(FABRICS).index(fabric)
    return np.random.default_rng(np.random.SeedSequence([seed, class_index, dye_index]))


def draw_parameters(spec: FabricSpec, dye: str, rng: np.random.Generator) -> Draw:
    """Random rotation, zoom, folds, light, material jitter and noise for one image."""
    u = rng.uniform
    folds = [
        {"amplitude": float(u(0.04, 0.11) * rng.choice([-1, 1])), "width": float(u(0.15, 0.4)),
         "angle_deg": float(u(0, 180)), "centre": float(u(-0.5, 0.5))}
        for _ in range(3)
    ]
    color = np.clip(np.array(DYES[dye]) * u(0.9, 1.1, size=3), 0.0, 0.95)
    backdrop = tuple(float(v) for v in np.full(3, u(0.1, 0.6))) if spec.open_weave else None
    return Draw(
        view_width=float(u(1.15, 1.45)),
        period_px=float(u(*spec.period_px)),
        rotation_deg=float(u(0, 180)),
        offset=(float(u(0, 8)), float(u(0, 8))),
        folds=folds,
        tilt_deg=float(u(0, 10)),
        tilt_axis_deg=float(u(0, 360)),
        light_polar_deg=float(u(12, 50)),
        light_azimuth_deg=float(u(0, 360)),
        light_distance=float(u(2.5, 3.5)),
        exposure=float(u(0.8, 1.1)),
        color=tuple(float(c) for c in color),
        roughness=float(u(*spec.roughness)),
        specular=float(u(*spec.specular)),
        backdrop=backdrop,
        noise_gain=float(u(2e-4, 6e-4)),
        noise_floor=float(u(1e-3, 3e-3)),
    )


def fold_surface(x: np.ndarray, y: np.ndarray, folds: list[dict[str, float]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fold displacement z(x, y) (sum of Gaussian ridges) and its gradient."""
    z, dzdx, dzdy = np.zeros_like(x), np.zeros_like(x), np.zeros_like(x)
    for fold in folds:
        angle = np.deg2rad(fold["angle_deg"])
        nx, ny = np.cos(angle), np.sin(angle)
        d = nx * x + ny * y - fold["centre"]
        ridge = fold["amplitude"] * np.exp(-0.5 * (d / fold["width"]) ** 2)
        z += ridge
        slope = -ridge * d / fold["width"] ** 2
        dzdx += slope * nx
        dzdy += slope * ny
    return z, dzdx, dzdy


class HeightField:
    """Thread height (world units) and yarn coverage at cloth coordinates (x, y)."""

    def __init__(self, spec: FabricSpec, draw: Draw, rng: np.random.Generator, mesh_resolution: int) -> None:
        self.spec = spec
        self.period = draw.period_px * draw.view_width / 256.0  # world units per thread
        angle = np.deg2rad(draw.rotation_deg)
        self.rotation = np.array([[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]])
        self.offset = np.array(draw.offset)
        self.jitter = rng.normal(0.0, 0.035, size=97)
        self.pile: np.ndarray | None = None
        if spec.structure == "pile":
            spacing = 2 * CLOTH_HALF / (mesh_resolution - 1)
            self.pile = pile_height((mesh_resolution, mesh_resolution), spec, rng, 0.5 * self.period / spacing)

    def thread_coords(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rotated cloth coordinates in thread periods (a across warps, b along them)."""
        a = (self.rotation[0, 0] * x + self.rotation[0, 1] * y) / self.period + self.offset[0]
        b = (self.rotation[1, 0] * x + self.rotation[1, 1] * y) / self.period + self.offset[1]
        return a, b

    def __call__(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.pile is not None:
            n = self.pile.shape[0]
            cols = (x + CLOTH_HALF) / (2 * CLOTH_HALF) * (n - 1)
            rows = (y + CLOTH_HALF) / (2 * CLOTH_HALF) * (n - 1)
            h = ndimage.map_coordinates(self.pile, [rows.ravel(), cols.ravel()], order=1, mode="wrap").reshape(x.shape)
            return h * self.period, np.ones_like(x, dtype=bool)
        a, b = self.thread_coords(x, y)
        if self.spec.structure == "knit":
            h, cover = knit_height(a, b, self.spec)
        else:
            h, cover = woven_height(a, b, self.spec, PATTERNS[self.spec.weave], self.jitter)
        return h * self.period, cover


def truth_maps(field: HeightField, view_width: float, resolution: int) -> dict[str, np.ndarray]:
    """Height map, tangent-space normal map and coverage over [-W/2, W/2]^2, row 0 at +y."""
    texel = view_width / resolution
    centres = (np.arange(resolution) + 0.5) * texel - view_width / 2
    x, y = np.meshgrid(centres, centres[::-1])
    height, coverage = field(x, y)
    eps = 0.25 * texel
    dhdx = (field(x + eps, y)[0] - field(x - eps, y)[0]) / (2 * eps)
    dhdy = (field(x, y + eps)[0] - field(x, y - eps)[0]) / (2 * eps)
    normal = np.stack([-dhdx, -dhdy, np.ones_like(dhdx)], axis=-1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return {"height": height, "normal": normal, "coverage": coverage}


def fold_map(folds: list[dict[str, float]], view_width: float) -> np.ndarray:
    """Fold displacement on the :data:`FOLD_GRID` square grid over [-W/2, W/2]^2, row 0 at +y."""
    axis = (np.arange(FOLD_GRID) + 0.5) / FOLD_GRID * view_width - view_width / 2
    fx, fy = np.meshgrid(axis, axis[::-1])
    return fold_surface(fx, fy, folds)[0]


def displaced_grid(field: HeightField, folds: list[dict[str, float]], n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(n, n, 3) cloth vertices: folds plus thread relief along the fold normal; coverage; texcoords."""
    coords = np.linspace(-CLOTH_HALF, CLOTH_HALF, n)
    x, y = np.meshgrid(coords, coords)
    z, dzdx, dzdy = fold_surface(x, y, folds)
    fold_normal = np.stack([-dzdx, -dzdy, np.ones_like(z)], axis=-1)
    fold_normal /= np.linalg.norm(fold_normal, axis=-1, keepdims=True)
    height, coverage = field(x, y)
    positions = np.stack([x, y, z], axis=-1) + height[..., None] * fold_normal
    a, b = field.thread_coords(x, y)
    return positions, coverage, np.stack([a, b], axis=-1)


def camera_and_light(draw: Draw, resolution: int) -> tuple[Camera, Light]:
    """Camera tilted about the cloth centre; light placed by polar/azimuth angles."""
    tilt, axis = np.deg2rad(draw.tilt_deg), np.deg2rad(draw.tilt_axis_deg)
    origin = CAMERA_DISTANCE * np.array([np.sin(tilt) * np.cos(axis), np.sin(tilt) * np.sin(axis), np.cos(tilt)])
    fov = float(np.rad2deg(2 * np.arctan(draw.view_width / 2 / CAMERA_DISTANCE)))
    polar, azimuth = np.deg2rad(draw.light_polar_deg), np.deg2rad(draw.light_azimuth_deg)
    position = draw.light_distance * np.array([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)])
    # intensity that makes a white Lambertian patch at the centre read ~0.85 before exposure jitter
    intensity = 0.85 * np.pi * draw.light_distance**2 / np.cos(polar) * draw.exposure
    camera = Camera(tuple(float(v) for v in origin), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), fov, resolution)
    return camera, Light(tuple(float(v) for v in position), 0.06, float(intensity))


def add_sensor_noise(linear: np.ndarray, draw: Draw, rng: np.random.Generator) -> np.ndarray:
    """Signal-dependent Gaussian noise (shot + read) in linear light."""
    sigma = np.sqrt(draw.noise_gain * np.clip(linear, 0, None) + draw.noise_floor**2)
    return linear + sigma * rng.standard_normal(linear.shape)


def quantise_srgb8(linear: np.ndarray) -> np.ndarray:
    """8-bit sRGB code values (as floats in [0, 1]) of a linear image."""
    return np.round(linear_to_srgb(linear) * 255.0) / 255.0


@dataclass
class Synthetic:
    """A rendered image (encoded sRGB in [0, 1]), its truth maps and truth record."""

    image: np.ndarray
    maps: dict[str, np.ndarray]
    fold: np.ndarray
    truth: dict[str, Any]


def synthesize(fabric: str, dye_index: int, seed: int, resolution: int, spp: int,
               mesh_resolution: int, variant: str, threads: int | None = None) -> Synthetic:
    """Generate one synthetic photo of ``fabric`` in dye number ``dye_index``.

    Raises
    ------
    ValueError
        For an unknown class or a dye index outside 0..5.
    """
    if fabric not in FABRICS:
        raise ValueError(f"unknown fabric class {fabric!r}; known: {', '.join(FABRICS)}")
    if not 0 <= dye_index < len(DYES):
        raise ValueError(f"dye_index must be in 0..{len(DYES) - 1}, got {dye_index}")

    started = time.perf_counter()
    spec, dye = FABRICS[fabric], list(DYES)[dye_index]
    rng = image_rng(seed, fabric, dye_index)
    draw = draw_parameters(spec, dye, rng)
    field = HeightField(spec, draw, rng, mesh_resolution)
    maps = truth_maps(field, draw.view_width, resolution)
    fold = fold_map(draw.folds, draw.view_width)

    mi = mitsuba_for(variant, threads)
    positions, coverage, texcoords = displaced_grid(field, draw.folds, mesh_resolution)
    bsdf = cloth_bsdf(mi, spec, np.array(draw.color), draw.roughness, draw.specular)
    keep = coverage if spec.open_weave else np.ones_like(coverage)
    mesh = cloth_mesh(mi, positions, texcoords, keep, bsdf)
    camera, light = camera_and_light(draw, resolution)
    effects = effects_for(spec, spp)
    render_seed = int(rng.integers(0, 2**31 - 1))
    scene = scene_dict(mi, mesh, camera, light, effects, None if draw.backdrop is None else np.array(draw.backdrop), render_seed)
    linear = render(mi, scene, render_seed)
    image = quantise_srgb8(add_sensor_noise(linear, draw, rng))

    truth = {
        "truth_version": TRUTH_VERSION,
        "fabric_class": fabric,
        "dye": dye,
        "seed": seed,
        "structure": spec.structure,
        "weave": spec.weave,
        "periodic": spec.periodic,
        "thread_period_px": draw.period_px if spec.periodic else None,
        "course_period_px": 0.8 * draw.period_px if spec.structure == "knit" else None,
        "fibre_scale_px": None if spec.periodic else draw.period_px,
        "thread_period_world": field.period,
        "weave_rotation_deg": draw.rotation_deg,
        "yarn_width_fraction": spec.yarn_width,
        "base_color_linear": list(draw.color),
        "roughness": draw.roughness,
        "specular": draw.specular,
        "anisotropic": spec.anisotropic,
        "sheen": spec.sheen,
        "backdrop_linear": None if draw.backdrop is None else list(draw.backdrop),
        "open_area_fraction": float(1 - maps["coverage"].mean()),
        "folds": draw.folds,
        "view_width_world": draw.view_width,
        "camera": asdict(camera),
        "light": {**asdict(light), "radiance": light.radiance, "polar_deg": draw.light_polar_deg,
                  "azimuth_deg": draw.light_azimuth_deg},
        "sensor_noise": {"gain": draw.noise_gain, "floor": draw.noise_floor, "quantisation": "8-bit sRGB"},
        "effects": effects,
        "mesh_resolution": mesh_resolution,
        "image_resolution": resolution,
        "height_range_world": [float(maps["height"].min()), float(maps["height"].max())],
        "render_seed": render_seed,
        "provenance": {"render_seconds": round(time.perf_counter() - started, 3), **runtime_metadata(mi)},
    }
    return Synthetic(image=image, maps=maps, fold=fold.astype(np.float32), truth=truth)


def quantise_height(height: np.ndarray, lo: float, hi: float, bits: int = 8) -> np.ndarray:
    """Height scaled to [0, 1] on a 2**bits grid (finer steps only cost file size)."""
    levels = 2**bits - 1
    return np.round((height - lo) / max(hi - lo, 1e-12) * levels) / levels


def save(synthetic: Synthetic, image_path: str | Path) -> dict[str, Path]:
    """Write the image and its ground truth atomically; returns the truth paths.

    The height map is an 8-bit PNG spanning ``height_range_world`` (the thread
    detail is in the normal map; the height map is for reference), the normal
    map an 8-bit PNG (``n * 0.5 + 0.5``), the fold displacement a float16 .npy
    on the 64 x 64 grid over the same square.
    """
    image_path = Path(image_path)
    paths = truth_paths(image_path)
    lo, hi = synthetic.truth["height_range_world"]
    write_png(image_path, synthetic.image)
    write_png(paths["normal"], encode_normal(synthetic.maps["normal"]))
    write_png(paths["height"], quantise_height(synthetic.maps["height"], lo, hi))
    write_with(paths["fold"], lambda tmp: np.save(str(tmp), synthetic.fold.astype(np.float16)))
    write_json(paths["json"], synthetic.truth)
    return paths


def dataset_index(colors_per_class: int) -> list[tuple[str, int, str]]:
    """(fabric class, dye index, image id) of every image of the default set."""
    return [(fabric, i, f"{fabric}_{list(DYES)[i]}") for fabric in FABRICS for i in range(colors_per_class)]


def synthesize_job(image_id: str, fabric: str, seed: int, settings: dict[str, Any], variant: str, threads: int,
                   target: str | Path) -> Synthetic:
    """The ``synthesize`` rule: render ``<fabric>_<dye>`` with the ``synthesize`` config and save it with its ground truth.

    Raises
    ------
    ValueError
        When the image id does not name one of :data:`DYES`.
    """
    dye = image_id.removeprefix(f"{fabric}_")
    if dye not in DYES:
        raise ValueError(f"image id {image_id!r} must be <class>_<dye> with a dye in {', '.join(DYES)}")
    result = synthesize(fabric, list(DYES).index(dye), seed, settings["resolution"], settings["spp"],
                        settings["mesh_resolution"], variant, threads)
    save(result, target)
    return result
