"""Shading with the yarn colours divided out: stripes and denim lose their colour pattern, one colour keeps its luminance."""
from __future__ import annotations

import numpy as np
import pytest

from clothscope.core.imageio import luminance
from clothscope.prepare.shading import dye_groups, shading


def threads_and_stripes(period: float = 9.0, stripe: int = 40, size: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """A thread-relief shading (cosines along both axes) under red and ecru warp stripes, linear RGB."""
    y, x = np.mgrid[:size, :size].astype(float)
    relief = 0.75 + 0.2 * np.cos(2 * np.pi * x / period) * np.cos(2 * np.pi * y / period)
    second = (x // stripe) % 2 == 1
    dye = np.where(second[..., None], [0.62, 0.58, 0.48], [0.55, 0.05, 0.05])
    return relief[..., None] * dye, relief


def test_stripes_are_divided_out_and_the_relief_stays():
    rgb, relief = threads_and_stripes()
    assert len(np.unique(dye_groups(rgb))) == 2
    found = shading(rgb)
    assert np.corrcoef(found.ravel(), relief.ravel())[0, 1] > 0.99
    assert np.corrcoef(luminance(rgb).ravel(), relief.ravel())[0, 1] < 0.5  # the luminance is mostly the stripes


@pytest.mark.parametrize("colour", [(0.55, 0.05, 0.05), (0.3, 0.3, 0.3), (0.0, 0.0, 0.0)])
def test_one_colour_keeps_its_luminance_up_to_a_constant(colour):
    _, relief = threads_and_stripes()
    rgb = relief[..., None] * np.array(colour)
    assert np.all(dye_groups(rgb) == 0)
    found = shading(rgb)
    assert np.all(np.isfinite(found))
    if max(colour) > 0:
        assert np.allclose(found / found.mean(), luminance(rgb) / luminance(rgb).mean())


def test_noisy_one_colour_photo_is_one_group():
    rng = np.random.default_rng(1)
    rgb = np.clip(np.array([0.08, 0.32, 0.10]) * (1 + 0.05 * rng.standard_normal((128, 128, 3))), 0, 1)
    assert np.all(dye_groups(rgb) == 0)


def test_a_dye_that_reads_darker_in_its_own_stripe_leaves_no_stripe_in_the_shading():
    """Navy weft between ecru warp reads lighter (blur, bounced light) than navy in a solid navy stripe."""
    from clothscope.features.structure import StructureSettings, analysis_field, find_lattice, spectrum

    size, period, stripe = 512, 8.0, 64
    y, x = np.mgrid[:size, :size].astype(float)
    relief = 0.75 + 0.2 * np.cos(2 * np.pi * x / period) * np.cos(2 * np.pi * y / period)
    solid = (x // stripe) % 2 == 1  # navy warp and weft; elsewhere ecru warp with navy weft dots
    weft = (np.floor(x / period) + np.floor(y / period)) % 2 == 1
    navy, ecru = np.array([0.03, 0.05, 0.30]), np.array([0.62, 0.58, 0.48])
    dye = np.where((solid | weft)[..., None], navy, ecru) * np.where(solid, 0.7, 1.0)[..., None]
    rgb = relief[..., None] * dye
    lattice = StructureSettings(border=0.0, peak_threshold=10.0, fundamental_fraction=1.0, lbp_scale="pixels")  # f0: the strongest
    strongest = find_lattice(spectrum(analysis_field(shading(rgb), 0.0)), lattice)
    assert size / strongest.f0 < 2 * period  # the threads (or their crossings), not the 128 px colour repeat
    groups = dye_groups(rgb)
    means = [luminance(rgb)[groups == g].mean() for g in range(groups.max() + 1)]
    divided = luminance(rgb) / np.array(means)[groups]  # one mean per dye only: the stripes stay
    assert size / find_lattice(spectrum(analysis_field(divided, 0.0)), lattice).f0 > 8 * period
