"""Capture-realistic synthetic photos: the "field" set.

The embedded set is clean (one dye, one small light, a 25-degree camera, no
blur, lossless PNG). This generator draws what real photos of cloth look
like, with the same kind of ground truth:

- cloth: the seven classes plus ``twill`` (2/1 or 3/1, denim-like two-colour
  warp and weft) and ``linen`` (plain weave of slub yarns); yarn-dyed stripes
  and checks, melange and fibre hairiness;
- capture: a phone camera (60-75 degree field of view, close up) under window
  light, its flash or a lamp, or a macro lens with a ring or coaxial light;
  native images of 1024-2048 px with thread periods of 3-60 px (a
  :class:`CaptureRange` narrows the captures and the threads across the frame);
- imaging: defocus, vignetting, white-balance shift, auto exposure (the
  mean of each pixel's brightest channel set to a mid grey; some frames
  over-exposed, where highlights clip), sensor noise and JPEG at quality 60-95.

Everything is a deterministic function of ``(seed, class, image number)``.
The truth maps cover the cloth square seen at the image centre, at the
native resolution, so ``thread_period_px`` is the period in native image
pixels at the centre of the frame.

Over 400 lines because the draws, the scene and the imaging pipeline of one capture are kept together.
"""
from __future__ import annotations

import io
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image
from scipy import ndimage

from clothscope.core.atomic import write_json, write_with
from clothscope.core.imageio import linear_to_srgb, write_png
from clothscope.core.mesh import cloth_mesh
from clothscope.core.runtime import mitsuba_for, runtime_metadata
from clothscope.core.truth import encode_normal, truth_paths
from clothscope.synth.fabrics import FABRICS, PLAIN, TWILL21, TWILL31, FabricSpec, knit_height, pile_height, woven_layers
from clothscope.synth.generate import CLOTH_HALF, PATTERNS, HeightField, displaced_grid, fold_map, quantise_height, truth_maps
from clothscope.synth.scene import Camera, cloth_bsdf, effects_for, render, scene_dict

FIELD_VERSION = 1

#: The paper's classes plus a twill and a slub plain weave.
FIELD_FABRICS: dict[str, FabricSpec] = {
    **FABRICS,
    "twill": FabricSpec("twill", "woven", "twill", (6.0, 12.0), 0.95, 0.18, 0.08, (0.55, 0.75), (0.3, 0.45)),
    "linen": FabricSpec("linen", "woven", "plain", (6.0, 12.0), 0.82, 0.20, 0.08, (0.6, 0.8), (0.25, 0.4)),
}

#: Dyes of the field set (linear RGB), drawn in pairs for multi-coloured cloth.
FIELD_DYES: dict[str, tuple[float, float, float]] = {
    "red": (0.55, 0.05, 0.05), "navy": (0.03, 0.05, 0.30), "green": (0.08, 0.32, 0.10),
    "mustard": (0.65, 0.42, 0.06), "ivory": (0.75, 0.73, 0.66), "charcoal": (0.035, 0.035, 0.04),
    "indigo": (0.03, 0.06, 0.18), "ecru": (0.62, 0.58, 0.48), "grey": (0.25, 0.25, 0.25),
    "pink": (0.7, 0.3, 0.35), "sky": (0.25, 0.45, 0.7),
}
CAPTURES = ("phone_window", "phone_flash", "phone_lamp", "macro_ring", "macro_coaxial")
COLOUR_SCHEMES = ("solid", "two_colour", "stripes", "checks", "melange")
RESOLUTIONS = (1024, 1536, 2048)
FOOTPRINT_HALF = 0.85  # the view stays inside this half width of the [-1, 1] cloth
THREADS_ACROSS = (12.0, 340.0)  # threads across the frame the generator allows
VERTICES_PER_THREAD = 8.0
#: Base colour read from the cloth mesh's per-vertex colours.
VERTEX_COLOUR = {"type": "mesh_attribute", "name": "vertex_color"}


@dataclass(frozen=True)
class FieldDraw:
    """The random choices behind one field image."""

    fabric: str
    weave_variant: str
    capture: str
    resolution: int
    fov_deg: float
    tilt_deg: float
    tilt_axis_deg: float
    period_px: float
    rotation_deg: float
    offset: tuple[float, float]
    folds: list[dict[str, float]]
    colour_scheme: str
    dyes: tuple[str, str]  # melange uses two shades of the first (the second name is drawn but unused)
    stripe_widths: tuple[int, int]
    slub: float
    hairiness: float
    roughness: float
    specular: float
    backdrop: tuple[float, float, float] | None
    light_polar_deg: float
    light_azimuth_deg: float
    ring_radius: float
    ambient: float
    defocus_px: float
    vignetting: float
    white_balance: tuple[float, float, float]
    exposure: float  # mean of the brightest channel (linear) the auto exposure aims at
    noise_gain: float
    noise_floor: float
    jpeg_quality: int


def field_index(images_per_class: int, classes: list[str] | None = None) -> list[tuple[str, int, str]]:
    """(fabric class, image number, image id) of every image of the field set, or of its ``classes`` only.

    An image depends on its class and number only (:func:`field_rng`), so a subset of
    classes renders the same images as the whole set does.

    Raises
    ------
    ValueError
        On a class the field set does not know.
    """
    chosen = list(FIELD_FABRICS) if not classes else list(classes)
    unknown = [c for c in chosen if c not in FIELD_FABRICS]
    if unknown:
        raise ValueError(f"unknown field class {', '.join(map(repr, unknown))}; known: {', '.join(FIELD_FABRICS)}")
    return [(fabric, k, f"{fabric}_{k:02d}") for fabric in FIELD_FABRICS if fabric in chosen for k in range(images_per_class)]


def field_rng(seed: int, fabric: str, number: int) -> np.random.Generator:
    """Independent, reproducible stream per (seed, class, image number)."""
    return np.random.default_rng(np.random.SeedSequence([seed, list(FIELD_FABRICS).index(fabric), number, 0xF1E1D]))


def draw_colour(spec: FabricSpec, weave_variant: str, rng: np.random.Generator) -> tuple[str, tuple[str, str], tuple[int, int]]:
    """Colour scheme, two dyes and stripe widths (threads); denim (3/1 twill) is indigo warp on ecru weft."""
    if weave_variant == "twill31" and rng.uniform() < 0.6:
        return "two_colour", ("indigo", "ecru"), (1, 1)
    schemes = ["solid", "melange"] if spec.structure == "pile" else list(COLOUR_SCHEMES)
    if spec.structure == "knit":
        schemes.remove("checks")
    scheme = str(rng.choice(schemes))
    first, second = rng.choice(list(FIELD_DYES), size=2, replace=False)
    widths = (int(rng.integers(2, 12)), int(rng.integers(2, 12)))
    return scheme, (str(first), str(second)), widths


@dataclass(frozen=True)
class CaptureRange:
    """Which captures a field set draws from, and how many threads its frames hold across."""

    captures: tuple[str, ...] = CAPTURES
    threads_across: tuple[float, float] = THREADS_ACROSS

    def __post_init__(self) -> None:
        unknown = [c for c in self.captures if c not in CAPTURES]
        if not self.captures or unknown:
            raise ValueError(f"captures must name some of {', '.join(CAPTURES)}, got {list(self.captures)}")
        low, high = self.threads_across
        if not 0 < low < high:
            raise ValueError(f"threads_across must be [low, high] with 0 < low < high, got {list(self.threads_across)}")

    @classmethod
    def from_settings(cls, settings: dict[str, Any]) -> CaptureRange:
        """From the ``synthesize.field`` config (an empty list: :data:`CAPTURES`, :data:`THREADS_ACROSS`)."""
        captures = tuple(settings.get("captures") or CAPTURES)
        low, high = settings.get("threads_across") or THREADS_ACROSS
        return cls(captures, (float(low), float(high)))


def draw_field(fabric: str, rng: np.random.Generator, captures: CaptureRange = CaptureRange()) -> FieldDraw:
    """Random cloth, capture and imaging for one image of ``fabric``, among ``captures``.

    The thread period is log-uniform over what ``captures.threads_across`` allows
    in the drawn frame, within 3-60 native pixels.
    """
    spec, u = FIELD_FABRICS[fabric], rng.uniform
    weave_variant = str(rng.choice(["twill21", "twill31"])) if spec.weave == "twill" else spec.weave
    capture = str(rng.choice(captures.captures))
    macro = capture.startswith("macro")
    resolution = int(rng.choice(RESOLUTIONS[:2] if macro else RESOLUTIONS))
    low = max(3.0, resolution / captures.threads_across[1])
    high = min(60.0, resolution / captures.threads_across[0])
    if low >= high:
        raise ValueError(f"threads_across {list(captures.threads_across)} leaves no period of 3-60 px in a {resolution} px frame")
    period = float(np.exp(u(np.log(low), np.log(high)))) if spec.periodic else float(u(2.0, 6.0))
    scheme, dyes, widths = draw_colour(spec, weave_variant, rng)
    fold_scale = 0.5 if macro else 1.0
    folds = [{"amplitude": float(fold_scale * u(0.03, 0.1) * rng.choice([-1, 1])), "width": float(u(0.15, 0.4)),
              "angle_deg": float(u(0, 180)), "centre": float(u(-0.5, 0.5))} for _ in range(3)]
    return FieldDraw(
        fabric=fabric, weave_variant=weave_variant, capture=capture, resolution=resolution,
        fov_deg=float(u(8, 20) if macro else u(60, 75)),
        tilt_deg=float(u(0, 5) if macro else u(0, 20)), tilt_axis_deg=float(u(0, 360)),
        period_px=period, rotation_deg=float(u(0, 180)), offset=(float(u(0, 8)), float(u(0, 8))), folds=folds,
        colour_scheme=scheme, dyes=dyes, stripe_widths=widths,
        slub=float(u(0.15, 0.35)) if fabric == "linen" else 0.0,
        hairiness=float(u(0.0, 0.2)), roughness=float(u(*spec.roughness)), specular=float(u(*spec.specular)),
        backdrop=tuple(float(v) for v in np.full(3, u(0.1, 0.6))) if spec.open_weave else None,
        light_polar_deg=float(u(15, 60)), light_azimuth_deg=float(u(0, 360)),
        ring_radius=float(u(0.15, 0.4)), ambient=float(u(0.02, 0.15)),
        defocus_px=float(u(0.0, 1.5) * resolution / 1024), vignetting=float(u(0.0, 0.35)),
        white_balance=tuple(float(v) for v in np.exp(rng.normal(0.0, 0.08, size=3))),
        exposure=float(u(0.35, 0.6) if u() < 0.3 else u(0.12, 0.25)), noise_gain=float(u(2e-4, 2e-3)), noise_floor=float(u(1e-3, 5e-3)),
        jpeg_quality=int(rng.integers(60, 96)),
    )


def camera_origin(distance: float, tilt_deg: float, tilt_axis_deg: float) -> np.ndarray:
    """Camera position at ``distance`` from the cloth centre, tilted about the given axis."""
    tilt, axis = np.deg2rad(tilt_deg), np.deg2rad(tilt_axis_deg)
    return distance * np.array([np.sin(tilt) * np.cos(axis), np.sin(tilt) * np.sin(axis), np.cos(tilt)])


def footprint_half_width(fov_deg: float, tilt_deg: float, tilt_axis_deg: float) -> float:
    """Largest |x| or |y| where the frame's corner rays meet z = 0, for a camera at distance 1."""
    origin = camera_origin(1.0, tilt_deg, tilt_axis_deg)
    forward = -origin / np.linalg.norm(origin)
    left = np.cross([0.0, 1.0, 0.0], forward)
    left /= np.linalg.norm(left)
    up = np.cross(forward, left)
    half = np.tan(np.deg2rad(fov_deg) / 2)
    corners = [forward + half * (sx * left + sy * up) for sx in (-1, 1) for sy in (-1, 1)]
    hits = [origin - origin[2] / ray[2] * ray for ray in corners]
    return float(max(np.abs(h[:2]).max() for h in hits))


class FieldHeight(HeightField):
    """Thread height, yarn colour and coverage of one field image's cloth (world units)."""

    def __init__(self, spec: FabricSpec, draw: FieldDraw, period_world: float, rng: np.random.Generator,
                 mesh_resolution: int) -> None:
        self.spec, self.draw, self.period = spec, draw, period_world
        angle = np.deg2rad(draw.rotation_deg)
        self.rotation = np.array([[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]])
        self.offset = np.array(draw.offset)
        self.jitter = rng.normal(0.0, 0.035, size=97)
        self.pattern = {"twill21": TWILL21, "twill31": TWILL31}.get(draw.weave_variant, PATTERNS.get(spec.weave, PLAIN))
        slub = ndimage.gaussian_filter1d(rng.standard_normal((97, 256)), sigma=6.0, axis=1, mode="wrap")
        self.slub = slub / (slub.std() + 1e-12)
        n = mesh_resolution
        spacing = 2 * CLOTH_HALF / (n - 1)
        self.pile = pile_height((n, n), spec, rng, 0.5 * period_world / spacing) if spec.structure == "pile" else None
        hair = ndimage.gaussian_filter(rng.standard_normal((n, n)), sigma=max(0.6, 0.05 * period_world / spacing), mode="wrap")
        self.hair = hair / (hair.std() + 1e-12)
        fibres = ndimage.gaussian_filter(rng.standard_normal((n, n)), sigma=max(0.6, 0.1 * period_world / spacing), mode="wrap")
        self.melange = fibres > np.quantile(fibres, 0.6)
        dyes = np.array([FIELD_DYES[d] for d in draw.dyes]) * rng.uniform(0.9, 1.1, size=(2, 3))
        if draw.colour_scheme == "melange":  # heather: fibres of one dye in a lighter and a darker shade
            dyes[1] = dyes[0] * rng.uniform(0.35, 0.65)
        self.dyes = np.clip(dyes, 0.0, 0.95)

    def grid_sample(self, grid: np.ndarray, x: np.ndarray, y: np.ndarray, order: int = 1) -> np.ndarray:
        """Bilinear lookup of a cloth-square grid at world (x, y)."""
        n = grid.shape[0]
        cols = (x + CLOTH_HALF) / (2 * CLOTH_HALF) * (n - 1)
        rows = (y + CLOTH_HALF) / (2 * CLOTH_HALF) * (n - 1)
        return ndimage.map_coordinates(grid, [rows.ravel(), cols.ravel()], order=order, mode="wrap").reshape(x.shape)

    def slub_scale(self, yarn: np.ndarray, along: np.ndarray) -> np.ndarray:
        """Yarn-width multiplier along each yarn (1 when the cloth has no slub)."""
        if not self.draw.slub:
            return np.ones_like(along)
        table = ndimage.map_coordinates(self.slub, [yarn.ravel() % 97, (along.ravel() * 4.0) % 256], order=1, mode="wrap")
        return np.clip(1.0 + self.draw.slub * table.reshape(along.shape), 0.5, 1.6)

    def layers(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Height (periods), coverage and warp-on-top of the weave or knit, before hairiness."""
        a, b = self.thread_coords(x, y)
        if self.spec.structure == "knit":
            height, cover = knit_height(a, b, self.spec)
            return height, cover, np.ones_like(cover)
        i, j = np.floor(a), np.floor(b)
        scale = (self.slub_scale(i, b), self.slub_scale(j + 41, a))
        return woven_layers(a, b, self.spec, self.pattern, self.jitter, scale)

    def __call__(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if self.pile is not None:
            return super().__call__(x, y)
        height, cover, _ = self.layers(x, y)
        hair = self.draw.hairiness * self.spec.relief * self.grid_sample(self.hair, x, y)
        return (height + np.where(cover, hair, 0.0)) * self.period, cover

    def colour(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Linear RGB base colour of the yarn seen at world (x, y)."""
        first, second = self.dyes
        scheme, (wide, narrow) = self.draw.colour_scheme, self.draw.stripe_widths
        if scheme == "melange":
            return np.where(self.grid_sample(self.melange.astype(float), x, y, order=0)[..., None] > 0.5, second, first)
        if scheme == "solid" or self.pile is not None:
            return np.broadcast_to(first, (*x.shape, 3)).copy()
        a, b = self.thread_coords(x, y)

        def banded(index: np.ndarray) -> np.ndarray:
            return (np.floor(index) % (wide + narrow)) >= wide

        if self.spec.structure == "knit":  # knit stripes run along the courses
            second_here = banded(b / 0.8)
        else:  # two_colour: warp first, weft second (denim); stripes in the warp; checks in both
            _, _, warp_on_top = self.layers(x, y)
            warp_second = banded(a) if scheme in ("stripes", "checks") else np.zeros(a.shape, dtype=bool)
            weft_second = banded(b) if scheme == "checks" else np.full(b.shape, scheme == "two_colour")
            second_here = np.where(warp_on_top, warp_second, weft_second)
        return np.where(second_here[..., None], second, first)


def field_lights(mi: Any, draw: FieldDraw, origin: np.ndarray, distance: float) -> dict[str, Any]:
    """Mitsuba emitters of the capture: window, flash, lamp, ring or coaxial light, plus ambient fill."""
    polar, azimuth = np.deg2rad(draw.light_polar_deg), np.deg2rad(draw.light_azimuth_deg)
    toward = np.array([np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)])
    lights: dict[str, Any] = {"ambient": {"type": "constant", "radiance": {"type": "rgb", "value": draw.ambient}}}
    if draw.capture == "phone_window":
        centre = 3.0 * distance * toward
        size = 1.5 * distance
        lights["window"] = {"type": "rectangle", "to_world": mi.ScalarTransform4f().look_at(
            origin=centre.tolist(), target=[0.0, 0.0, 0.0], up=[0.0, 0.0, 1.0] if abs(toward[2]) < 0.99 else [0.0, 1.0, 0.0]
        ).scale([size, size, 1.0]), "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 1.0}}}
    elif draw.capture == "phone_lamp":
        centre = 2.5 * distance * toward
        lights["lamp"] = {"type": "sphere", "center": centre.tolist(), "radius": 0.05 * distance,
                          "emitter": {"type": "area", "radiance": {"type": "rgb", "value": 1.0 / (0.05 * distance) ** 2}}}
    elif draw.capture == "macro_ring":
        forward = -origin / distance
        side = np.cross(forward, [0.0, 0.0, 1.0] if abs(forward[2]) < 0.99 else [1.0, 0.0, 0.0])
        side /= np.linalg.norm(side)
        other = np.cross(forward, side)
        for k in range(8):
            phi = 2 * np.pi * k / 8
            position = origin + draw.ring_radius * distance * (np.cos(phi) * side + np.sin(phi) * other)
            lights[f"ring{k}"] = {"type": "point", "position": position.tolist(), "intensity": {"type": "rgb", "value": 1.0}}
    else:  # phone_flash: beside the lens; macro_coaxial: through the lens
        offset = 0.02 * distance if draw.capture == "phone_flash" else 0.0
        lights["flash"] = {"type": "point", "position": (origin + [offset, offset, 0.0]).tolist(),
                           "intensity": {"type": "rgb", "value": 1.0}}
    return lights


def develop(linear: np.ndarray, draw: FieldDraw, rng: np.random.Generator) -> np.ndarray:
    """Camera processing of a linear render: defocus, vignetting, white balance, auto exposure, noise; sRGB in [0, 1]."""
    image = ndimage.gaussian_filter(linear, sigma=(draw.defocus_px, draw.defocus_px, 0)) if draw.defocus_px > 0.05 else linear
    n = image.shape[0]
    r2 = np.sum(np.square(np.mgrid[0:n, 0:n] - (n - 1) / 2), axis=0) / (n / 2) ** 2 / 2
    image = image * (1.0 - draw.vignetting * r2)[..., None] * np.array(draw.white_balance)
    image = image * draw.exposure / max(float(np.mean(image.max(axis=-1))), 1e-6)
    sigma = np.sqrt(draw.noise_gain * np.clip(image, 0, None) + draw.noise_floor**2)
    image = np.clip(image + sigma * rng.standard_normal(image.shape), 0.0, 1.0)
    return linear_to_srgb(image)


def encode_jpeg(srgb: np.ndarray, quality: int) -> bytes:
    """8-bit JPEG bytes of an sRGB image in [0, 1]."""
    buffer = io.BytesIO()
    Image.fromarray(np.round(np.clip(srgb, 0, 1) * 255).astype(np.uint8)).save(buffer, "JPEG", quality=quality)
    return buffer.getvalue()


@dataclass
class FieldPhoto:
    """A field photo (JPEG bytes), its truth maps and truth record."""

    jpeg: bytes
    maps: dict[str, np.ndarray]
    fold: np.ndarray
    truth: dict[str, Any]


def synthesize_field(fabric: str, number: int, seed: int, spp: int, max_mesh_resolution: int,
                     variant: str, threads: int | None = None, scale: float = 1.0,
                     captures: CaptureRange = CaptureRange()) -> FieldPhoto:
    """Generate field image number ``number`` of ``fabric``, its capture drawn among ``captures``.

    ``scale`` < 1 renders the same scene at a fraction of its native
    resolution (thread period and defocus scale with it), for tests.

    Raises
    ------
    ValueError
        For an unknown class or a negative image number.
    """
    if fabric not in FIELD_FABRICS:
        raise ValueError(f"unknown field class {fabric!r}; known: {', '.join(FIELD_FABRICS)}")
    if number < 0:
        raise ValueError(f"image number must be >= 0, got {number}")
    if not 0.0 < scale <= 1.0:
        raise ValueError(f"scale must be in (0, 1], got {scale}")

    started = time.perf_counter()
    spec, rng = FIELD_FABRICS[fabric], field_rng(seed, fabric, number)
    draw = draw_field(fabric, rng, captures)
    if scale != 1.0:
        draw = replace(draw, resolution=int(round(draw.resolution * scale)), period_px=draw.period_px * scale,
                       defocus_px=draw.defocus_px * scale)
    distance = FOOTPRINT_HALF / footprint_half_width(draw.fov_deg, draw.tilt_deg, draw.tilt_axis_deg)
    origin = camera_origin(distance, draw.tilt_deg, draw.tilt_axis_deg)
    pixel_world = 2 * distance * np.tan(np.deg2rad(draw.fov_deg) / 2) / draw.resolution  # at the image centre
    period_world = draw.period_px * pixel_world
    threads_on_cloth = 2 * CLOTH_HALF / period_world
    mesh_resolution = int(np.clip(VERTICES_PER_THREAD * threads_on_cloth, 512, max_mesh_resolution))
    field = FieldHeight(spec, draw, period_world, rng, mesh_resolution)

    view_width = pixel_world * draw.resolution
    maps = truth_maps(field, view_width, draw.resolution)
    fold = fold_map(draw.folds, view_width)

    mi = mitsuba_for(variant, threads)
    positions, coverage, texcoords = displaced_grid(field, draw.folds, mesh_resolution)
    coords = np.linspace(-CLOTH_HALF, CLOTH_HALF, mesh_resolution)
    colour = field.colour(*np.meshgrid(coords, coords))  # the vertices' cloth coordinates, as displaced_grid lays them
    bsdf = cloth_bsdf(mi, spec, VERTEX_COLOUR, draw.roughness, draw.specular)
    keep = coverage if spec.open_weave else np.ones_like(coverage)
    mesh = cloth_mesh(mi, positions, texcoords, keep, bsdf)
    mesh.add_attribute(VERTEX_COLOUR["name"], 3, mi.Float(colour.reshape(-1).astype(np.float32)))
    camera = Camera(tuple(float(v) for v in origin), (0.0, 0.0, 0.0), (0.0, 1.0, 0.0), draw.fov_deg, draw.resolution)
    effects = {**effects_for(spec, spp), "capture": draw.capture, "ambient_light": True}
    render_seed = int(rng.integers(0, 2**31 - 1))
    scene = scene_dict(mi, mesh, camera, None, effects, None if draw.backdrop is None else np.array(draw.backdrop), render_seed)
    scene.update(field_lights(mi, draw, origin, distance))
    linear = render(mi, scene, render_seed)
    srgb = develop(linear, draw, rng)
    jpeg = encode_jpeg(srgb, draw.jpeg_quality)

    truth = {
        "truth_version": FIELD_VERSION, "dataset": "field", "fabric_class": fabric, "seed": seed, "number": number,
        "structure": spec.structure, "weave": draw.weave_variant, "periodic": spec.periodic,
        "thread_period_px": draw.period_px if spec.periodic else None,
        "course_period_px": 0.8 * draw.period_px if spec.structure == "knit" else None,
        "fibre_scale_px": None if spec.periodic else draw.period_px,
        "thread_period_world": period_world, "weave_rotation_deg": draw.rotation_deg,
        "yarn_width_fraction": spec.yarn_width,
        "base_color_linear": colour.reshape(-1, 3).mean(axis=0).tolist(),
        "roughness": draw.roughness, "specular": draw.specular, "anisotropic": spec.anisotropic, "sheen": spec.sheen,
        "backdrop_linear": None if draw.backdrop is None else list(draw.backdrop),
        "open_area_fraction": float(1 - maps["coverage"].mean()), "folds": draw.folds,
        "view_width_world": view_width, "camera": asdict(camera), "camera_distance_world": distance,
        "draw": asdict(draw), "effects": effects, "mesh_resolution": mesh_resolution,
        "image_resolution": draw.resolution,
        "height_range_world": [float(maps["height"].min()), float(maps["height"].max())],
        "render_seed": render_seed,
        "provenance": {"render_seconds": round(time.perf_counter() - started, 3), **runtime_metadata(mi)},
    }
    return FieldPhoto(jpeg=jpeg, maps=maps, fold=fold.astype(np.float32), truth=truth)


def save_field(photo: FieldPhoto, image_path: str | Path) -> dict[str, Path]:
    """Write the JPEG and its ground truth atomically (as :func:`clothscope.synth.generate.save`)."""
    image_path = Path(image_path)
    paths = truth_paths(image_path)
    lo, hi = photo.truth["height_range_world"]
    write_with(image_path, lambda tmp: tmp.write_bytes(photo.jpeg))
    write_png(paths["normal"], encode_normal(photo.maps["normal"]))
    write_png(paths["height"], quantise_height(photo.maps["height"], lo, hi))
    write_with(paths["fold"], lambda tmp: np.save(str(tmp), photo.fold.astype(np.float16)))
    write_json(paths["json"], photo.truth)
    return paths


def synthesize_field_job(image_id: str, fabric: str, settings: dict[str, Any], variant: str, threads: int,
                         target: str | Path) -> FieldPhoto:
    """The ``synthesize_field`` rule: render ``<fabric>_<number>`` with the ``synthesize.field`` config and save it.

    Raises
    ------
    ValueError
        When the image id does not end in a number.
    """
    number = image_id.removeprefix(f"{fabric}_")
    if not number.isdigit():
        raise ValueError(f"image id {image_id!r} must be <class>_<two-digit number>")
    photo = synthesize_field(fabric, int(number), settings["seed"], settings["spp"], settings["max_mesh_resolution"],
                             variant, threads, captures=CaptureRange.from_settings(settings))
    save_field(photo, target)
    return photo
