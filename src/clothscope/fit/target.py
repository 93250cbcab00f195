"""The photo a fit stage compares its renders with: the prepared image at a resolution, its weights and the loss."""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

import drjit as dr
import numpy as np

from clothscope.core.imageio import decode_exr, linear_to_srgb, read_png
from clothscope.prepare.image import CLIPPED_FILE, IMAGE_FILE, read_status, resize_channel


class SkipStage(Exception):
    """The input of a stage was rejected upstream; the stage records a skip."""


@dataclass
class Target:
    """A photo at one resolution and its per-pixel weights (0 on clipped pixels)."""

    image: np.ndarray
    weight: np.ndarray
    cache: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def resolution(self) -> int:
        return int(self.image.shape[0])


def load_prepared(prepared_dir: str | os.PathLike[str]) -> Target:
    """The working image and clipped mask of a prepared image; SkipStage if it was rejected."""
    status = read_status(prepared_dir)
    if status.get("status") != "accepted":
        raise SkipStage(f"rejected by prepare: {status.get('reason', '')}")

    decoded = decode_exr(Path(prepared_dir) / IMAGE_FILE, 1, 1e9)
    clipped = read_png(Path(prepared_dir) / CLIPPED_FILE) > 0.5
    return Target(decoded.rgb.astype(np.float32), (~clipped).astype(np.float32))


def box_downsample(array: np.ndarray, size: int) -> np.ndarray:
    """Area-average an (H, W[, C]) array to size x size (exact block means when H is a multiple of size)."""
    height = array.shape[0]
    if height == size:
        return array.astype(np.float32)
    if height % size == 0:
        f = height // size
        shape = (size, f, size, f) + array.shape[2:]
        return array.reshape(shape).mean(axis=(1, 3)).astype(np.float32)
    if array.ndim == 2:
        return resize_channel(array, size)
    return np.stack([resize_channel(array[..., c], size) for c in range(array.shape[2])], axis=-1)


def at_resolution(target: Target, size: int) -> Target:
    """The target box-filtered to ``size`` px; a pixel counts only if no clipped pixel fell into it."""
    return Target(box_downsample(target.image, size), (box_downsample(target.weight, size) > 0.999).astype(np.float32))


def image_loss(mi: ModuleType, rendered: Any, target: Target) -> Any:
    """Weighted mean squared error, normalised by the target's mean square (so black cloth still has gradients)."""
    if "loss" not in target.cache:  # device copies and constants made once per stage, not per iteration
        weight = np.repeat(target.weight[..., None], 3, axis=2)
        scale = 1.0 / ((float(weight.sum()) + 1.0) * (float(np.mean(target.image**2)) + 1e-6))
        target.cache["loss"] = (mi.TensorXf(target.image), mi.TensorXf(weight * scale))
    t, w = target.cache["loss"]
    return dr.sum((rendered - t) ** 2 * w, axis=None)


#: The floor of :func:`unexplained_share`'s denominator: the variance of a photo that holds no contrast at all.
SHARE_FLOOR = 1e-6


def unexplained_share(rendered: np.ndarray, target: Target) -> float:
    """The fit's residual energy over the photo's own variance about its mean, summed over RGB (linear).

    Over unclipped pixels; 0 where the render equals the photo, about 1 where it explains no more than the
    photo's mean colour. A brightness gain on photo and fit leaves it unchanged; a colour gain only reweighs
    the channels.
    """
    w = target.weight[..., None] * np.ones(3)
    photo = target.image.astype(np.float64)
    mean = (photo * w).sum(axis=(0, 1)) / max(float(target.weight.sum()), 1.0)
    spread = float(np.sum((photo - mean) ** 2 * w))
    return float(np.sum((rendered.astype(np.float64) - photo) ** 2 * w) / max(spread, SHARE_FLOOR))


def psnr(rendered: np.ndarray, target: Target) -> float:
    """PSNR (dB) of the sRGB-encoded images over unclipped pixels, capped at 99 dB."""
    a = linear_to_srgb(np.clip(rendered, 0.0, 1.0))
    b = linear_to_srgb(np.clip(target.image, 0.0, 1.0))
    w = target.weight[..., None] * np.ones(3)
    mse = float(np.sum((a - b) ** 2 * w) / max(np.sum(w), 1.0))
    return float(min(99.0, 10 * np.log10(1.0 / max(mse, 1e-10))))
