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
"""
from __future__ import annotations

import numpy as np
from scipy.cluster.vq import ClusterError, kmeans2

from .fit.light import luminance

#: most dye groups looked for
MAX_COLOURS = 3
#: smallest chromaticity distance (r, g of r + g + b = 1) between two dye groups
MIN_SEPARATION = 0.04
#: groups must also lie this many within-group RMS spreads apart (noise on one dye is one blob, not two)
SEPARATION_OVER_SPREAD = 4.0
#: pixels sampled for the clustering
SAMPLE = 20000


def chromaticity(rgb: np.ndarray) -> np.ndarray:
    """(..., 2) red and green shares of r + g + b (1/3 each for grey and black)."""
    total = rgb.sum(axis=-1, keepdims=True)
    safe = np.where(total > 1e-6, total, 1.0)
    return np.where(total > 1e-6, rgb[..., :2] / safe, 1.0 / 3.0)


def dye_groups(rgb: np.ndarray, seed: int = 0) -> np.ndarray:
    """(H, W) dye-group label of each pixel: 0 for every pixel of a one-colour photo."""
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


def shading(rgb: np.ndarray) -> np.ndarray:
    """(H, W) luminance over the mean luminance of the pixel's dye group (linear RGB in)."""
    grey = luminance(rgb)
    groups = dye_groups(rgb)
    means = np.array([grey[groups == g].mean() if np.any(groups == g) else 1.0 for g in range(groups.max() + 1)])
    return grey / np.maximum(means[groups], 1e-6)
