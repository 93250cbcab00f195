"""Colour model of the normal-map fit, chosen from the photo: one colour, or the photo's dye layout.

One base colour makes the fit explain a yarn-dyed cloth's colour pattern
(stripes, checks, denim's indigo warp on ecru weft) with tilted normals. When
the working photo holds more than one dye group
(:func:`clothscope.prepare.shading.dye_groups`), the ``dye_layout`` model makes the
base colour the fitted colour times a fixed *layout* texture: each texel's
dye-group mean colour over the photo's mean colour, so the fitted colour stays
the cloth's mean colour. The layout is read from the photo, not optimised, so
no relief can leak into it. The choice is recorded in the stage's ``state.json``.

A pixel on the edge between two yarns of different dyes shows a mixture of
their colours (defocus, downscaling). ``layout_mixing: mixed`` gives each pixel
the non-negative least-squares mixture of the groups' mean colours that
matches it (:func:`mixed_colours`); ``hard`` gives it its group's mean.

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
from itertools import combinations
from typing import Any

import numpy as np
from scipy import ndimage

from clothscope.core.imageio import luminance
from clothscope.fit.model import texel_centres
from clothscope.prepare.shading import chromaticity, dye_groups

#: values of ``fit.normals.colour_model``
COLOUR_MODELS = ("auto", "one_colour", "dye_layout")
#: values of ``fit.normals.layout_mixing``: each pixel its group's mean colour, or the mixture of the means that matches it
LAYOUT_MIXINGS = ("hard", "mixed")
#: ``auto`` and ``mixed``: linear luminance below which a pixel's chromaticity is mostly noise (8-bit sRGB codes below about 18)
DARK_LUMINANCE = 0.005
#: ``auto``: two groups are two dyes when the chromaticity density between them dips to this fraction of the lower peak
VALLEY_FRACTION = 0.7
#: ``mixed``: a group whose mean colour a non-negative mixture of the others' reaches within this fraction of its length
#: is a band of mixed pixels (yarn edges), not a dye of its own (:func:`dye_colours`)
MIXTURE_TOLERANCE = 0.05
#: histogram of the pixels' position along the line between two groups (0 at one group's mean, 1 at the other's)
LINE_BINS, LINE_RANGE, LINE_SMOOTHING = 40, (-0.5, 1.5), 1.0


@dataclass(frozen=True)
class ColourModel:
    """The base colour's model: ``one_colour`` or ``dye_layout`` with its (T, T, 3) layout texture and its mixing."""

    kind: str
    layout: np.ndarray | None = None
    shares: tuple[float, ...] = (1.0,)
    mixing: str = "hard"

    def as_record(self) -> dict[str, Any]:
        """What ``state.json`` records: the kind, the number of groups that hold any photo pixel, every group's share
        and, for a layout, how its pixels' colours were taken (:data:`LAYOUT_MIXINGS`)."""
        record = {"kind": self.kind, "dye_groups": sum(1 for s in self.shares if s > 0),
                  "shares": [round(float(s), 4) for s in self.shares]}
        return record | ({"mixing": self.mixing} if self.layout is not None else {})


def texel_samples(image: np.ndarray, texture: int, margin: float) -> np.ndarray:
    """The photo pixel under each texel of the plane, which overhangs the view by ``margin`` in all (edge pixels extend)."""
    size = image.shape[0]
    index = np.clip(np.floor(texel_centres(texture, margin) * size).astype(int), 0, size - 1)
    return image[np.ix_(index, index)]


def mixture_weights(colours: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """(N, K) non-negative weights ``u`` minimising ``|c - u @ basis|`` for each of the (N, 3) ``colours``.

    Non-negative least squares over K <= 3 basis colours, solved over every subset of them:
    the best subset whose unconstrained solution is non-negative is the optimum. A colour
    that only the zero mixture reaches gets zero weights.
    """
    best_residual = np.sum(colours**2, axis=1)
    best = np.zeros((len(colours), len(basis)))
    for k in range(1, len(basis) + 1):
        for subset in combinations(range(len(basis)), k):
            weights = np.zeros_like(best)
            weights[:, subset] = np.linalg.lstsq(basis[list(subset)].T, colours.T, rcond=None)[0].T
            residual = np.sum((colours - weights @ basis) ** 2, axis=1)
            better = np.all(weights >= 0, axis=1) & (residual < best_residual - 1e-15)
            best_residual[better] = residual[better]
            best[better] = weights[better]
    return best


def mixed_colours(photo: np.ndarray, means: np.ndarray) -> np.ndarray:
    """(H, W, 3) colour of each pixel as a mixture of the groups' mean colours (``means``, (K, 3), K <= 3).

    The mixture is ``u @ means / sum(u)`` for the pixel's :func:`mixture_weights` ``u``: the
    pixel's colour with its shading (``sum(u)``, alike for every group) divided out. A pixel
    that no mixture reaches gets the means' average.
    """
    weights = mixture_weights(photo.reshape(-1, 3), means)
    total = weights.sum(axis=1, keepdims=True)
    mixed = np.where(total > 1e-12, weights @ means / np.maximum(total, 1e-12), means.mean(axis=0))
    return mixed.reshape(photo.shape)


def mixture_residual(colour: np.ndarray, basis: np.ndarray) -> float:
    """Distance from ``colour`` to the nearest non-negative mixture of the ``basis`` rows, over the colour's length."""
    weights = mixture_weights(colour[None], basis)[0]
    return float(np.linalg.norm(colour - weights @ basis) / max(float(np.linalg.norm(colour)), 1e-12))


def dye_colours(means: np.ndarray) -> np.ndarray:
    """The rows of ``means`` (group mean colours) that are dyes: of three or more, a group that the others mix to
    within :data:`MIXTURE_TOLERANCE` (the band of pixels where two yarns meet) is dropped, the closest first."""
    dyes = np.asarray(means, dtype=np.float64)
    while len(dyes) > 2:
        residuals = [mixture_residual(dyes[g], np.delete(dyes, g, axis=0)) for g in range(len(dyes))]
        closest = int(np.argmin(residuals))
        if residuals[closest] >= MIXTURE_TOLERANCE:
            break
        dyes = np.delete(dyes, closest, axis=0)
    return dyes


def check_mixing(mixing: str) -> None:
    """Raise a ``ValueError`` unless ``mixing`` is one of :data:`LAYOUT_MIXINGS`."""
    if mixing not in LAYOUT_MIXINGS:
        raise ValueError(f"layout_mixing must be one of {', '.join(LAYOUT_MIXINGS)}, got {mixing!r}")


def layout_texture(photo: np.ndarray, groups: np.ndarray, texture: int, margin: float,
                   mixing: str) -> tuple[np.ndarray, tuple[float, ...]]:
    """(T, T, 3) texture of each texel's dye colour over the photo's mean colour, and the groups' area shares.

    ``mixing`` (:data:`LAYOUT_MIXINGS`): ``hard``, the texel's dye-group mean colour;
    ``mixed``, the mixture of the dyes' mean colours (:func:`dye_colours`) that matches the pixel
    (:func:`mixed_colours`), except for pixels darker than :data:`DARK_LUMINANCE`, which keep their group's mean.
    """
    check_mixing(mixing)
    count = int(groups.max()) + 1
    shares = np.array([np.mean(groups == g) for g in range(count)])
    means = np.array([photo[groups == g].mean(axis=0) if shares[g] > 0 else np.zeros(3) for g in range(count)])
    colours = means[groups]
    if mixing == "mixed":
        bright = luminance(photo) >= DARK_LUMINANCE
        colours[bright] = mixed_colours(photo[bright][None], dye_colours(means[shares > 0]))[0]
    ratios = colours / np.maximum(shares @ means, 1e-6)
    return texel_samples(ratios, texture, margin).astype(np.float32), tuple(float(s) for s in shares)


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


def choose_colour_model(kind: str, photo: np.ndarray, texture: int, margin: float, mixing: str) -> ColourModel:
    """The colour model of ``kind`` for a working photo (finite linear RGB); ``mixing`` as in :func:`layout_texture`.

    A photo with one dye group always gets ``one_colour``; under ``auto`` so does one whose groups fail
    :func:`distinct_dyes`.

    Raises
    ------
    ValueError
        When ``kind`` is not one of :data:`COLOUR_MODELS`, or ``mixing`` not one of :data:`LAYOUT_MIXINGS`.
    """
    check_mixing(mixing)
    if kind not in COLOUR_MODELS:
        raise ValueError(f"colour_model must be one of {', '.join(COLOUR_MODELS)}, got {kind!r}")
    if kind == "one_colour":
        return ColourModel("one_colour")
    rgb = np.asarray(photo, dtype=np.float64)[..., :3]
    groups = dye_groups(rgb)
    if groups.max() == 0 or (kind == "auto" and not distinct_dyes(rgb, groups)):
        return ColourModel("one_colour")
    layout, shares = layout_texture(rgb, groups, texture, margin, mixing)
    return ColourModel("dye_layout", layout, shares, mixing)
