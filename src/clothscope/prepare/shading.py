"""Shading of a cloth photo with its yarn colours divided out.

Yarn-dyed cloth (stripes, checks, denim's indigo warp on ecru weft) puts its
strongest luminance pattern at the colour repeat, not at the thread pitch.
Relief shading scales all three channels alike, while a change of dye changes
the chromaticity, so the pixels are grouped by chromaticity (k-means, at most
:data:`MAX_COLOURS` groups, kept only while the groups are at least
:data:`MIN_SEPARATION` and :data:`SEPARATION_OVER_SPREAD` times their own
spread apart) and each pixel's luminance is divided by the
mean luminance of its group. A one-colour photo has one group, and its
shading is its luminance divided by a constant.

A dye does not read the same everywhere: a navy weft dot between ecru warp
floats is lightened by defocus and by light bounced off its neighbours, so it
reads lighter than the navy of a solid stripe. Dividing by one mean per group
then leaves a step at every colour repeat. The shading is therefore also
cleared of what the dye layout explains: its least-squares fit on each
group's map blurred at :data:`LAYOUT_SCALES` is subtracted (its constant term kept).
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from clothscope.core.imageio import luminance

#: most dye groups looked for
MAX_COLOURS = 3
#: smallest chromaticity distance (r, g of r + g + b = 1) between two dye groups
MIN_SEPARATION = 0.04
#: groups must also lie this many within-group RMS spreads apart (noise on one dye is one blob, not two)
SEPARATION_OVER_SPREAD = 4.0
#: pixels sampled for the clustering
SAMPLE = 20000
#: blur scales (pixels) of the dye-group maps whose fit is taken out of the shading: from a dot's own blur to a stripe
LAYOUT_SCALES = (1.0, 2.0, 4.0, 8.0, 16.0, 32.0)


def chromaticity(rgb: np.ndarray) -> np.ndarray:
    """(..., 2) red and green shares of r + g + b (1/3 each for grey and black)."""
    total = rgb.sum(axis=-1, keepdims=True)
    safe = np.where(total > 1e-6, total, 1.0)
    return np.where(total > 1e-6, rgb[..., :2] / safe, 1.0 / 3.0)


def dye_groups(rgb: np.ndarray, seed: int = 0) -> np.ndarray:
    """(H, W) dye-group label of each pixel: 0 for every pixel of a one-colour photo."""
    from scipy.cluster.vq import ClusterError, kmeans2  # imported here, so fit jobs that never split dyes skip it

    chroma = chromaticity(rgb.reshape(-1, 3))
    rng = np.random.default_rng(seed)
    sample = chroma[rng.choice(len(chroma), size=min(SAMPLE, len(chroma)), replace=False)]
    labels = np.zeros(len(chroma), dtype=np.int64)
    if np.ptp(sample, axis=0).max() < MIN_SEPARATION:  # one colour (or black): nothing to split
        return labels.reshape(rgb.shape[:2])
    for k in range(MAX_COLOURS, 1, -1):
        try:
            centres, _ = kmeans2(sample, k, minit="++", seed=seed, missing="raise")
        except ClusterError:  # an empty group: fewer dyes than k
            continue
        gaps = np.linalg.norm(centres[:, None] - centres[None], axis=-1)[np.triu_indices(k, 1)]
        nearest = np.argmin(np.linalg.norm(sample[:, None] - centres[None], axis=-1), axis=1)
        spread = float(np.sqrt(np.mean(np.sum((sample - centres[nearest]) ** 2, axis=1))))
        if gaps.min() >= max(MIN_SEPARATION, SEPARATION_OVER_SPREAD * spread):
            labels = np.argmin(np.linalg.norm(chroma[:, None] - centres[None], axis=-1), axis=1)
            break
    return labels.reshape(rgb.shape[:2])


def without_layout(field: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """``field`` less the blurred dye-group maps' part of its least-squares fit (the constant term kept); unchanged for one group."""
    maps = [ndimage.gaussian_filter((groups == g).astype(np.float64), sigma, mode="reflect").ravel()
            for g in range(int(groups.max())) for sigma in LAYOUT_SCALES]
    if not maps:
        return field
    columns = [np.ones(field.size)] + maps  # normal equations: a few columns of a million pixels each
    gram = np.array([[a @ b for b in columns] for a in columns])
    coefficients = np.linalg.lstsq(gram, np.array([a @ field.ravel() for a in columns]), rcond=None)[0]
    return field - sum(c * m for c, m in zip(coefficients[1:], maps)).reshape(field.shape)


def shading(rgb: np.ndarray) -> np.ndarray:
    """(H, W) luminance over the mean luminance of the pixel's dye group, less what the dye layout explains (linear RGB in)."""
    grey = luminance(rgb)
    groups = dye_groups(rgb)
    means = np.array([grey[groups == g].mean() if np.any(groups == g) else 1.0 for g in range(groups.max() + 1)])
    return without_layout(grey / np.maximum(means[groups], 1e-6), groups)
