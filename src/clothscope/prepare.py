"""Stage 0, ``prepare``: decode a photo into the working image every fit starts from.

Decodes, applies EXIF orientation, converts sRGB to linear, centre-crops to a
square, resizes to the working resolution and marks clipped pixels. A bad
image is not an error of the run: :func:`prepare_image` records a rejection
with a one-line reason instead.
"""
from __future__ import annotations

import json
import os
import traceback
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image

from .atomic import atomic_dir, write_json
from .imageio import ImageRejected, decode_image, linear_to_srgb, write_exr, write_png

STATUS_FILE = "status.json"
IMAGE_FILE = "image.exr"
CLIPPED_FILE = "clipped.png"
PREVIEW_FILE = "preview.png"


@dataclass(frozen=True)
class PrepareSettings:
    """Knobs of the prepare stage (``prepare:`` in the config)."""

    working_resolution: int = 256
    min_input_px: int = 64
    max_megapixels: float = 100.0
    clip_threshold: float = 0.98
    max_clipped_fraction: float = 0.5

    def __post_init__(self) -> None:
        if self.working_resolution < 16:
            raise ValueError(f"working_resolution must be >= 16, got {self.working_resolution}")
        if not 0.0 < self.clip_threshold <= 1.0:
            raise ValueError(f"clip_threshold must be in (0, 1], got {self.clip_threshold}")


def centre_square(array: np.ndarray) -> np.ndarray:
    """Crop the largest centred square from an (H, W, ...) array."""
    height, width = array.shape[:2]
    side = min(height, width)
    top, left = (height - side) // 2, (width - side) // 2
    return array[top : top + side, left : left + side]


def resize_channel(channel: np.ndarray, size: int) -> np.ndarray:
    """Area-average (down) or bicubic (up) resize of one float channel to size x size."""
    method = Image.Resampling.BOX if channel.shape[0] >= size else Image.Resampling.BICUBIC
    resized = Image.fromarray(np.ascontiguousarray(channel, dtype=np.float32), mode="F").resize((size, size), method)
    return np.asarray(resized, dtype=np.float32)


def to_working_resolution(rgb: np.ndarray, clipped: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Centre-crop and resize linear RGB and the clipped mask to ``size`` x ``size``.

    A working pixel is clipped when any source pixel under it was clipped.
    """
    square = centre_square(rgb)
    out = np.stack([resize_channel(square[..., c], size) for c in range(3)], axis=-1)
    mask = resize_channel(centre_square(clipped).astype(np.float32), size) > 1e-6
    return np.clip(out, 0.0, None), mask


def prepare_image(image_id: str, path: str | os.PathLike[str], out_dir: str | os.PathLike[str], settings: PrepareSettings) -> dict[str, Any]:
    """Prepare one image into ``out_dir`` (written atomically) and return its status record.

    The record's ``status`` is ``"accepted"`` or ``"rejected"``; a rejected image
    has a one-line ``reason`` and no pixel outputs.
    """
    record: dict[str, Any] = {"image_id": image_id, "path": str(path), "settings": asdict(settings)}
    with atomic_dir(out_dir) as tmp:
        try:
            decoded = decode_image(path, settings.min_input_px, settings.max_megapixels, settings.clip_threshold)
            rgb, clipped = to_working_resolution(decoded.rgb, decoded.clipped, settings.working_resolution)
            fraction = float(clipped.mean())
            if fraction > settings.max_clipped_fraction:
                raise ImageRejected(
                    f"{path}: {fraction:.0%} of the image is clipped (limit {settings.max_clipped_fraction:.0%}); "
                    "expose it darker"
                )
            write_exr(tmp / IMAGE_FILE, rgb)
            write_png(tmp / CLIPPED_FILE, clipped.astype(np.float32))
            write_png(tmp / PREVIEW_FILE, linear_to_srgb(rgb))
            record.update(
                status="accepted",
                reason="",
                source_format=decoded.source_format,
                bit_depth=decoded.bit_depth,
                source_size=[int(decoded.rgb.shape[1]), int(decoded.rgb.shape[0])],
                clipped_fraction=fraction,
                mean_linear_rgb=[float(v) for v in rgb.reshape(-1, 3).mean(axis=0)],
                notes=decoded.notes,
            )
        except ImageRejected as err:
            record.update(status="rejected", reason=str(err))
        except Exception as err:  # noqa: BLE001 - one bad image must not sink the run
            first_line = (str(err).splitlines() or [""])[0]
            record.update(
                status="rejected",
                reason=f"{path}: unexpected {type(err).__name__} while decoding: {first_line}",
                traceback=traceback.format_exc(),
            )
        write_json(tmp / STATUS_FILE, record)
    return record


def read_status(prepared_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """Read the status record of a prepared image folder."""
    return json.loads((Path(prepared_dir) / STATUS_FILE).read_text(encoding="utf-8"))
