"""Colour model of the normal-map fit, chosen from the photo: one colour, or the photo's dye layout.

One base colour makes the fit explain a yarn-dyed cloth's colour pattern
(stripes, checks, denim's indigo warp on ecru weft) with tilted normals. When
the working photo holds more than one dye group
(:func:`clothscope.prepare.shading.dye_groups`), the ``dye_layout`` model makes the
base colour the fitted colour times a fixed *layout* texture: each texel's
dye-group mean colour over the photo's mean colour, so the fitted colour stays
the cloth's mean colour. The layout is read from the photo, not optimised, so
no relief can leak into it. The choice is recorded in the stage's ``state.json``.

``dye_layout`` uses the layout whenever the photo holds more than one dye
group. ``auto`` asks for more evidence, because one dye can split into
chromaticity groups too: a specular highlight or a grey backdrop seen through
a sheer cloth mixes the dye with a neutral colour in every proportion, and
near-black pixels (holes over a dark backdrop) have a chromaticity that is
mostly noise. ``auto`` therefore sets aside pixels and groups darker than
:data:`DARK_LUMINANCE` and picks ``dye_layout`` only when the two largest
remaining groups are two modes of the pixels' chromaticity: along the line
joining the chromaticities of the two groups' mean colours, the density of the
remaining pixels between the two peaks dips to at most :data:`VALLEY_FRACTION`
of the lower peak. Dyes meet at yarn edges, so few pixels lie between them; a
highlight fades into the dye, so its pixels fill the line.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import ndimage

from clothscope.core.imageio import luminance
from clothscope.fit.model import texel_centres
from clothscope.prepare.shading import chromaticity, dye_groups

#: values of ``fit.normals.colour_model``
COLOUR_MODELS = ("auto", "one_colour", "dye_layout")
#: ``auto``: linear luminance below which a pixel's chromaticity is mostly noise (8-bit sRGB codes below about 18)
DARK_LUMINANCE = 0.005
#: ``auto``: two groups are two dyes when the chromaticity density between them dips to this fraction of the lower peak
VALLEY_FRACTION = 0.7
#: histogram of the pixels' position along the line between two groups (0 at one group's mean, 1 at the other's)
LINE_BINS, LINE_RANGE, LINE_SMOOTHING = 40, (-0.5, 1.5), 1.0


@dataclass(frozen=True)
class ColourModel:
    """The base colour's model: ``one_colour`` or ``dye_layout`` with its (T, T, 3) layout texture."""

    kind: str
    layout: np.ndarray | None = None
    shares: tuple[float, ...] = (1.0,)

    def as_record(self) -> dict[str, Any]:
        """What ``state.json`` records: the kind, the number of groups that hold any photo pixel, and every group's share."""
        return {"kind": self.kind, "dye_groups": sum(1 for s in self.shares if s > 0),
                "shares": [round(float(s), 4) for s in self.shares]}


def texel_groups(groups: np.ndarray, texture: int, margin: float) -> np.ndarray:
    """(T, T) dye group under each texel of the plane, which overhangs the view by ``margin`` in all (edge groups extend)."""
    size = groups.shape[0]
    index = np.clip(np.floor(texel_centres(texture, margin) * size).astype(int), 0, size - 1)
    return groups[np.ix_(index, index)]


def layout_texture(photo: np.ndarray, groups: np.ndarray, texture: int, margin: float) -> tuple[np.ndarray, tuple[float, ...]]:
    """(T, T, 3) texture of each texel's dye-group mean colour over the photo's mean colour, and the groups' area shares."""
    count = int(groups.max()) + 1
    shares = np.array([np.mean(groups == g) for g in range(count)])
    means = np.array([photo[groups == g].mean(axis=0) if shares[g] > 0 else np.zeros(3) for g in range(count)])
    ratios = means / np.maximum(shares @ means, 1e-6)
    return ratios[texel_groups(groups, texture, margin)].astype(np.float32), tuple(float(s) for s in shares)


def valley_ratio(chroma: np.ndarray, first: np.ndarray, second: np.ndarray) -> float:
    """Lowest chromaticity density between two groups' peaks over the lower peak (1 when one group has no peak of its own).

    ``chroma`` holds the pixels' (N, 2) chromaticities; ``first`` and ``second`` are the chromaticities of two groups'
    mean colours.
    """
    line = second - first
    position = (chroma - first) @ line / max(float(line @ line), 1e-12)
    counts, edges = np.histogram(position, bins=LINE_BINS, range=LINE_RANGE)
    density = ndimage.gaussian_filter1d(counts.astype(np.float64), LINE_SMOOTHING)
    centres = 0.5 * (edges[:-1] + edges[1:])
    low = int(np.argmax(np.where(centres < 0.5, density, -1.0)))
    high = int(np.argmax(np.where(centres > 0.5, density, -1.0)))
    lower_peak = min(density[low], density[high])
    if lower_peak <= 0:
        return 1.0
    return float(density[low:high + 1].min() / lower_peak)


def distinct_dyes(photo: np.ndarray, groups: np.ndarray) -> bool:
    """Whether the two largest groups that are not near-black are two modes of the pixels' chromaticity (``auto``'s test).

    ``photo`` is (H, W, 3) finite linear RGB and ``groups`` its (H, W) dye groups.
    """
    grey = luminance(photo)
    usable = grey >= DARK_LUMINANCE
    sizes = np.bincount(groups.ravel(), minlength=int(groups.max()) + 1)
    dyes = [g for g in np.argsort(sizes)[::-1] if sizes[g] > 0 and grey[groups == g].mean() >= DARK_LUMINANCE][:2]
    if len(dyes) < 2 or not usable.any():
        return False
    first, second = (chromaticity(photo[groups == g].mean(axis=0)) for g in dyes)
    chroma = chromaticity(photo[usable])
    return valley_ratio(chroma, first, second) <= VALLEY_FRACTION


def choose_colour_model(kind: str, photo: np.ndarray, texture: int, margin: float) -> ColourModel:
    """The colour model of ``kind`` for a working photo (finite linear RGB).

    A photo with one dye group always gets ``one_colour``; under ``auto`` so does one whose groups fail
    :func:`distinct_dyes`.

    Raises
    ------
    ValueError
        When ``kind`` is not one of :data:`COLOUR_MODELS`.
    """
    if kind not in COLOUR_MODELS:
        raise ValueError(f"colour_model must be one of {', '.join(COLOUR_MODELS)}, got {kind!r}")
    if kind == "one_colour":
        return ColourModel("one_colour")
    rgb = np.asarray(photo, dtype=np.float64)[..., :3]
    groups = dye_groups(rgb)
    if groups.max() == 0 or (kind == "auto" and not distinct_dyes(rgb, groups)):
        return ColourModel("one_colour")
    layout, shares = layout_texture(rgb, groups, texture, margin)
    return ColourModel("dye_layout", layout, shares)
