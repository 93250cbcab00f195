"""Extra training rows of one map: tiles (sub-windows) and views (the map turned or zoomed).

The classifier trains on them as extra rows of their image (:func:`clothscope.classify.rows.with_tiles`)
and never scores an image by them. Tiles show how one cloth varies from place to place; views show it
at another orientation or camera distance. Each is described by
:func:`clothscope.features.structure.texture_columns`, like the whole map.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from clothscope.features.structure import MIN_FIELD, StructureSettings, texture_columns, window


@dataclass(frozen=True)
class TileSettings:
    """Sub-windows and views described as extra training rows (``features.tiles`` in the config schema, which holds the defaults)."""

    grid: int
    size: float
    turns: tuple[float, ...] = ()
    zooms: tuple[float, ...] = ()


def tile_fields(field: np.ndarray, border: float, tiles: TileSettings) -> list[np.ndarray]:
    """``grid`` x ``grid`` overlapping squares of the analysis window, each ``size`` of its side.

    Evenly spaced from corner to corner; none (an empty list) with ``grid`` 0
    or when a tile would be smaller than :data:`MIN_FIELD` pixels.

    Raises
    ------
    ValueError
        When ``grid`` is negative or ``size`` is not in (0, 1].
    """
    if tiles.grid < 0 or not 0.0 < tiles.size <= 1.0:
        raise ValueError(f"tiles need grid >= 0 and size in (0, 1], got {tiles.grid} and {tiles.size}")
    whole = window(field, border)
    side = whole.shape[0]
    size = int(round(tiles.size * side))
    if tiles.grid == 0 or size < MIN_FIELD:
        return []
    starts = np.linspace(0, side - size, tiles.grid).round().astype(int)
    return [whole[r : r + size, c : c + size] for r in starts for c in starts]


def turned(square: np.ndarray, degrees: float) -> np.ndarray:
    """``square`` turned by ``degrees`` (bilinear), cut to the largest upright centred square inside the turned one."""
    side = square.shape[0]
    angle = np.radians(degrees)
    keep = int(side / (abs(np.cos(angle)) + abs(np.sin(angle))) + 1e-9)  # exact at multiples of 90 degrees
    start = (side - keep) // 2
    rotated = ndimage.rotate(square, degrees, reshape=False, order=1, mode="reflect")
    return rotated[start : start + keep, start : start + keep]


def zoomed(square: np.ndarray, factor: float) -> np.ndarray:
    """``square`` seen ``factor`` times closer (bilinear): above 1 its centre magnified back to the same side,
    below 1 the whole square shrunk (threads look finer)."""
    if factor > 1.0:
        side = square.shape[0]
        keep = int(round(side / factor))
        start = (side - keep) // 2
        return ndimage.zoom(square[start : start + keep, start : start + keep], side / keep, order=1)
    return ndimage.zoom(square, factor, order=1)


def view_fields(field: np.ndarray, border: float, tiles: TileSettings) -> list[np.ndarray]:
    """The analysis window turned by each of ``tiles.turns`` (degrees) and zoomed by each of ``tiles.zooms``.

    These views show the classifier the same cloth at another orientation and camera
    distance, so it learns to ignore them. None (an empty list) when one would be smaller than
    :data:`MIN_FIELD` pixels.

    Raises
    ------
    ValueError
        When a zoom is not positive and finite, or a turn is not finite.
    """
    if not all(np.isfinite(t) for t in tiles.turns) or not all(np.isfinite(z) and z > 0 for z in tiles.zooms):
        raise ValueError(f"views need finite turns and positive zooms, got {list(tiles.turns)} and {list(tiles.zooms)}")
    whole = window(field, border)
    views = [turned(whole, t) for t in tiles.turns] + [zoomed(whole, z) for z in tiles.zooms]
    return views if all(min(v.shape) >= MIN_FIELD for v in views) else []


def view_periods(period_px: float | None, tiles: TileSettings) -> list[float | None]:
    """The thread period of each :func:`view_fields` view, from the field's: a turn keeps it, a zoom scales it."""
    if period_px is None:
        return [None] * (len(tiles.turns) + len(tiles.zooms))
    return [period_px] * len(tiles.turns) + [period_px * z for z in tiles.zooms]


def tile_columns(field: np.ndarray, settings: StructureSettings, tiles: TileSettings,
                 period_px: float | None = None) -> dict[int, dict[str, float]]:
    """:func:`texture_columns` of each extra training row's field, by row number: the :func:`tile_fields`
    as 0 .. grid^2 - 1, then the :func:`view_fields` from grid^2 on (the same numbers on every source).
    ``period_px``: the field's thread period measured elsewhere (None: each row's own)."""
    inner = StructureSettings(0.0, settings.peak_threshold, settings.fundamental_fraction, settings.lbp_scale)
    numbered = [(k, f, period_px) for k, f in enumerate(tile_fields(field, settings.border, tiles))]
    views = view_fields(field, settings.border, tiles)
    numbered += [(tiles.grid**2 + k, view, p) for k, (view, p) in enumerate(zip(views, view_periods(period_px, tiles)))]
    return {k: texture_columns(f, inner, p) for k, f, p in numbered}
