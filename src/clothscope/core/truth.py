"""Ground-truth records of a synthetic photo: where they live beside it, and the normal-map encoding."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def encode_normal(normal: np.ndarray) -> np.ndarray:
    """Tangent-space unit normals -> the usual RGB normal-map encoding in [0, 1]."""
    return 0.5 * normal + 0.5


def decode_normal(encoded: np.ndarray) -> np.ndarray:
    """Inverse of :func:`encode_normal`, renormalised to unit length."""
    normal = 2.0 * np.asarray(encoded, dtype=np.float32) - 1.0
    return normal / np.maximum(np.linalg.norm(normal, axis=-1, keepdims=True), 1e-6)


def truth_paths(image_path: Path) -> dict[str, Path]:
    """Where the ground truth of ``<id>.png`` lives: beside it, marked ``.truth``."""
    stem = image_path.with_suffix("")
    return {
        "json": Path(f"{stem}.truth.json"),
        "normal": Path(f"{stem}.truth-normal.png"),
        "height": Path(f"{stem}.truth-height.png"),
        "fold": Path(f"{stem}.truth-fold.npy"),
    }
