"""Colour model of the normal-map fit, chosen from the photo: one colour, or the photo's dye layout.

One base colour makes the fit explain a yarn-dyed cloth's colour pattern
(stripes, checks, denim's indigo warp on ecru weft) with tilted normals. When
the working photo holds more than one dye group
(:func:`clothscope.shading.dye_groups`), the ``dye_layout`` model makes the
base colour the fitted colour times a fixed *layout* texture: each texel's
dye-group mean colour over the photo's mean colour, so the fitted colour stays
the cloth's mean colour. The layout is read from the photo, not optimised, so
no relief can leak into it. ``auto`` picks ``dye_layout`` when the photo holds
more than one dye group and ``one_colour`` otherwise; the choice is recorded in
the stage's ``state.json``.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..shading import dye_groups

#: values of ``fit.normals.colour_model``
COLOUR_MODELS = ("auto", "one_colour", "dye_layout")


@dataclass(frozen=True)
class ColourModel:
    """The base colour's model: ``one_colour`` or ``dye_layout`` with its (T, T, 3) layout texture."""

    kind: str
    layout: np.ndarray | None = None
    shares: tuple[float, ...] = (1.0,)

    def as_record(self) -> dict[str, Any]:
        return {"kind": self.kind, "dye_groups": len(self.shares), "shares": [round(float(s), 4) for s in self.shares]}


def texel_groups(groups: np.ndarray, texture: int, margin: float) -> np.ndarray:
    """(T, T) dye group under each texel of the plane, which overhangs the view by ``margin`` in all (edge groups extend)."""
    size = groups.shape[0]
    centres = ((np.arange(texture) + 0.5) / texture - 0.5) * (1.0 + margin) + 0.5  # texel centres in view fractions
    index = np.clip(np.floor(centres * size).astype(int), 0, size - 1)
    return groups[np.ix_(index, index)]


def layout_texture(photo: np.ndarray, groups: np.ndarray, texture: int, margin: float) -> tuple[np.ndarray, tuple[float, ...]]:
    """(T, T, 3) texture of each texel's dye-group mean colour over the photo's mean colour, and the groups' area shares."""
    count = int(groups.max()) + 1
    shares = np.array([np.mean(groups == g) for g in range(count)])
    means = np.array([photo[groups == g].mean(axis=0) if shares[g] > 0 else np.zeros(3) for g in range(count)])
    ratios = means / np.maximum(shares @ means, 1e-6)
    return ratios[texel_groups(groups, texture, margin)].astype(np.float32), tuple(float(s) for s in shares)


def choose_colour_model(kind: str, photo: np.ndarray, texture: int, margin: float) -> ColourModel:
    """The colour model of ``kind`` for a working photo (linear RGB); a photo with one dye group always gets ``one_colour``.

    Raises
    ------
    ValueError
        When ``kind`` is not one of :data:`COLOUR_MODELS`.
    """
    if kind not in COLOUR_MODELS:
        raise ValueError(f"colour_model must be one of {', '.join(COLOUR_MODELS)}, got {kind!r}")
    if kind == "one_colour":
        return ColourModel("one_colour")
    groups = dye_groups(np.asarray(photo, dtype=np.float64)[..., :3])
    if groups.max() == 0:
        return ColourModel("one_colour")
    layout, shares = layout_texture(np.asarray(photo, dtype=np.float64)[..., :3], groups, texture, margin)
    return ColourModel("dye_layout", layout, shares)
