"""frame_candidate.py: the photo's whole-frame descriptor: finite, blind to exposure and quarter turns, and sensitive to texture."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "benchmarks"))
from frame_candidate import (  # noqa: E402
    FRAME_COLUMNS,
    FRAME_LBP_COLUMNS,
    FRAME_RING_COLUMNS,
    FRAME_SIZE,
    frame_columns,
    frame_field,
)


def ribbed_photo(width: int = 600, height: int = 400, period: float = 9.0, seed: int = 0) -> np.ndarray:
    """A grey photo of ribs with a little noise (linear RGB)."""
    x = np.arange(width)[None, :] * np.ones((height, 1))
    grey = 0.3 + 0.1 * np.sin(2 * np.pi * x / period) + 0.01 * np.random.default_rng(seed).standard_normal((height, width))
    return np.repeat(grey[..., None], 3, axis=2)


def test_every_column_is_finite_and_each_lbp_scale_is_a_histogram():
    columns = frame_columns(ribbed_photo())
    assert list(columns) == list(FRAME_COLUMNS) and len(FRAME_RING_COLUMNS) == 10
    assert all(np.isfinite(v) for v in columns.values())
    for prefix in ("f_lbp_8_1_", "f_lbp_16_2_", "f_lbp_24_3_"):
        assert sum(columns[c] for c in FRAME_LBP_COLUMNS if c.startswith(prefix)) == pytest.approx(1.0)


def test_the_frame_is_the_centred_square_of_the_photo():
    photo = ribbed_photo(width=900, height=300)
    photo[:, :300] = 1.0  # outside the centred 300 px square
    assert frame_field(photo).shape == (FRAME_SIZE, FRAME_SIZE) and frame_field(photo).max() < 0.6


def test_exposure_and_a_quarter_turn_barely_move_the_columns():
    photo = ribbed_photo(width=512, height=512)
    base = np.array(list(frame_columns(photo).values()))
    darker = np.array(list(frame_columns(0.4 * photo).values()))
    turned = np.array(list(frame_columns(np.rot90(photo).copy()).values()))
    assert np.abs(darker - base).max() < 1e-5
    assert np.abs(turned - base).max() < 0.05


def test_ribs_and_noise_differ_and_a_flat_photo_gives_flat_rings():
    ribs = np.array(list(frame_columns(ribbed_photo()).values()))
    noise = np.array(list(frame_columns(np.random.default_rng(1).uniform(0.2, 0.4, (400, 600, 3))).values()))
    assert np.abs(ribs - noise).max() > 0.1
    flat = frame_columns(np.full((300, 300, 3), 0.25))
    assert all(flat[c] == 0.0 for c in FRAME_RING_COLUMNS)


def test_a_photo_that_is_not_rgb_or_not_finite_is_a_clear_error():
    with pytest.raises(ValueError, match="an \\(H, W, 3\\) photo"):
        frame_columns(np.zeros((40, 40)))
    bad = ribbed_photo()
    bad[200, 300] = np.nan
    with pytest.raises(ValueError, match="NaN or infinite"):
        frame_columns(bad)
