"""Procedural thread-level micro-structure of the seven fabric classes.

Each class is a :class:`FabricSpec` (structure, scale, reflectance and the
rendering effects it calls for) and a height field ``h(a, b)`` over cloth
coordinates measured in thread periods. Heights are in the same units
(periods), so the relief scales with the thread size.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

#: Weave matrices: 1 where the warp yarn (along b) lies over the weft (along a).
PLAIN = np.array([[1, 0], [0, 1]])
BASKET = np.array([[1, 1, 0, 0], [1, 1, 0, 0], [0, 0, 1, 1], [0, 0, 1, 1]])
#: 5-harness warp-faced satin: each warp floats over four wefts, under one.
SATIN5 = 1 - np.array([[1 if (j - 2 * i) % 5 == 0 else 0 for i in range(5)] for j in range(5)])
#: Warp-faced twills: each warp floats over two (2/1) or three (3/1, denim) wefts, stepping one per row.
TWILL21 = np.array([[1 if (i - j) % 3 < 2 else 0 for i in range(3)] for j in range(3)])
TWILL31 = np.array([[1 if (i - j) % 4 < 3 else 0 for i in range(4)] for j in range(4)])


@dataclass(frozen=True)
class FabricSpec:
    """What the generator draws for one fabric class.

    ``period_px`` is the thread period range in working-image pixels at the
    nominal zoom; ``yarn_width`` is the yarn diameter as a fraction of the
    period; ``relief`` the yarn thickness, and ``undulation`` the over/under
    crossing amplitude, both in periods.
    """

    name: str
    structure: str  # "woven", "knit" or "pile"
    weave: str  # "plain", "basket", "satin5", "jersey", "pile"
    period_px: tuple[float, float]
    yarn_width: float
    relief: float
    undulation: float
    roughness: tuple[float, float]
    specular: tuple[float, float]
    anisotropic: float = 0.0
    sheen: float = 0.0
    sheer: bool = False  # translucent yarns: diffuse transmission, path tracing
    open_weave: bool = False  # gaps between yarns are holes showing a backdrop

    @property
    def periodic(self) -> bool:
        return self.structure != "pile"


FABRICS: dict[str, FabricSpec] = {
    spec.name: spec
    for spec in (
        FabricSpec("broadcloth", "woven", "plain", (6.5, 8.0), 0.92, 0.16, 0.07, (0.45, 0.6), (0.35, 0.5)),
        FabricSpec("canvas", "woven", "basket", (11.0, 14.0), 0.95, 0.22, 0.10, (0.65, 0.8), (0.25, 0.4)),
        FabricSpec("satin", "woven", "satin5", (6.5, 8.0), 0.96, 0.12, 0.05, (0.18, 0.28), (0.6, 0.8), anisotropic=0.7),
        FabricSpec("chiffon", "woven", "plain", (8.0, 10.0), 0.45, 0.14, 0.05, (0.35, 0.5), (0.4, 0.55), sheer=True, open_weave=True),
        FabricSpec("cotton_gauze", "woven", "plain", (11.0, 14.0), 0.55, 0.20, 0.08, (0.7, 0.85), (0.2, 0.35), open_weave=True),
        FabricSpec("knit_jersey", "knit", "jersey", (8.0, 10.0), 0.22, 0.18, 0.0, (0.55, 0.7), (0.3, 0.45)),
        FabricSpec("velvet", "pile", "pile", (3.0, 4.0), 0.0, 0.10, 0.0, (0.75, 0.9), (0.2, 0.35), sheen=1.0),
    )
}


def yarn_profile(x: np.ndarray) -> np.ndarray:
    """Cross-section of a yarn at signed offset ``x`` (1 = yarn edge): cosine bump, -inf outside."""
    inside = np.abs(x) < 1.0
    return np.where(inside, np.cos(0.5 * np.pi * np.clip(x, -1, 1)), -np.inf)


def crossing_elevation(along: np.ndarray, states: np.ndarray) -> np.ndarray:
    """Smooth over/under elevation in [-1, 1] along a yarn, cosine-interpolated between crossings.

    ``along`` is the coordinate along the yarn in periods; ``states`` maps each
    sample to (+1 over / -1 under) at the crossing below (index 0) and above
    (index 1) the sample.
    """
    frac = along - 0.5 - np.floor(along - 0.5)
    blend = 0.5 - 0.5 * np.cos(np.pi * frac)
    return states[0] * (1 - blend) + states[1] * blend


def woven_height(a: np.ndarray, b: np.ndarray, spec: FabricSpec, pattern: np.ndarray, jitter: np.ndarray,
                 width_scale: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Height (periods) and yarn coverage of a woven fabric at cloth coordinates (a, b) in periods.

    Warp yarns run along b (column i = floor(a)), weft yarns along a (row j = floor(b)).
    ``jitter`` holds small per-yarn centre offsets (periods), indexed modulo its length.
    ``width_scale`` optionally multiplies the yarn width of the warp and the weft
    at each sample (slub yarns: thick and thin places along a yarn).
    """
    return woven_layers(a, b, spec, pattern, jitter, width_scale)[:2]


def woven_layers(a: np.ndarray, b: np.ndarray, spec: FabricSpec, pattern: np.ndarray, jitter: np.ndarray,
                 width_scale: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`woven_height`'s height and coverage, plus where the warp lies on top (for yarn colours)."""
    repeat = pattern.shape[0]
    i = np.floor(a).astype(np.int64)
    j = np.floor(b).astype(np.int64)
    warp_width, weft_width = (spec.yarn_width, spec.yarn_width) if width_scale is None else (
        spec.yarn_width * width_scale[0], spec.yarn_width * width_scale[1])
    warp_x = (a - i - 0.5 - jitter[i % len(jitter)]) * 2 / warp_width
    weft_x = (b - j - 0.5 - jitter[(j + 7) % len(jitter)]) * 2 / weft_width
    # crossing rows below/above the sample along each yarn
    j_lo = np.floor(b - 0.5).astype(np.int64)
    i_lo = np.floor(a - 0.5).astype(np.int64)
    warp_states = [2 * pattern[(j_lo + k) % repeat, i % repeat] - 1 for k in (0, 1)]
    weft_states = [1 - 2 * pattern[j % repeat, (i_lo + k) % repeat] for k in (0, 1)]
    warp = spec.undulation * crossing_elevation(b, np.array(warp_states)) + spec.relief * yarn_profile(warp_x)
    weft = spec.undulation * crossing_elevation(a, np.array(weft_states)) + spec.relief * yarn_profile(weft_x)
    floor = -spec.undulation - 0.5 * spec.relief
    height = np.maximum(np.maximum(warp, weft), floor)
    coverage = (np.abs(warp_x) < 1) | (np.abs(weft_x) < 1)
    return height, coverage, warp >= weft


def _segment_distance(px, py, ax, ay, bx, by):
    """Distance from points (px, py) to the segment (ax, ay)-(bx, by)."""
    dx, dy = bx - ax, by - ay
    t = np.clip(((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy), 0.0, 1.0)
    return np.hypot(px - ax - t * dx, py - ay - t * dy)


def knit_height(a: np.ndarray, b: np.ndarray, spec: FabricSpec, course_ratio: float = 0.8) -> tuple[np.ndarray, np.ndarray]:
    """Height of a single-jersey face: raised columns (wales, one per period along a) of V-shaped loops.

    Each wale is a ridge between grooves; on it, two yarn legs form a V per
    course, courses ``course_ratio`` periods apart along b.
    """
    s = a - np.floor(a)
    t = b / course_ratio - np.floor(b / course_ratio)
    column = np.cos(np.pi * (s - 0.5)) * (0.85 + 0.15 * np.cos(2 * np.pi * t))
    left = _segment_distance(s, t * course_ratio, 0.5, 0.0, 0.15, course_ratio)
    right = _segment_distance(s, t * course_ratio, 0.5, 0.0, 0.85, course_ratio)
    legs = np.maximum(yarn_profile(np.minimum(left, right) / (spec.yarn_width / 2)), 0.0)
    height = spec.relief * (0.6 * column + 0.4 * legs)
    return height, np.ones_like(height, dtype=bool)


def pile_height(shape: tuple[int, int], spec: FabricSpec, rng: np.random.Generator, fibre_px: float) -> np.ndarray:
    """Non-periodic pile: white noise low-passed at the fibre scale, unit variance times relief."""
    noise = ndimage.gaussian_filter(rng.standard_normal(shape), sigma=fibre_px, mode="wrap")
    noise /= noise.std() + 1e-12
    return spec.relief * noise
