"""The photo's repeat and the repeat prior of the normal-map fit (clothscope.fit.repeat)."""
from __future__ import annotations

import numpy as np
import pytest

from clothscope.fit.repeat import (
    MIN_CORRELATION,
    Repeat,
    photo_repeats,
    repeat_penalty_np,
    repeat_samples,
    shifted_samples,
    texel_shift,
)


def woven_photo(size: int = 128, period: float = 10.0, turn_deg: float = 0.0) -> np.ndarray:
    """A grey plain-weave-like photo: crossings of a ``period`` px thread lattice turned by ``turn_deg``."""
    y, x = np.mgrid[:size, :size].astype(float)
    a = np.deg2rad(turn_deg)
    u, v = x * np.cos(a) + y * np.sin(a), -x * np.sin(a) + y * np.cos(a)
    checker = np.sin(np.pi * u / period) * np.sin(np.pi * v / period)  # over / under alternates every thread
    relief = 0.5 + 0.2 * checker
    return np.repeat(relief[..., None], 3, axis=2) * np.array([0.6, 0.3, 0.2])


def lattice_member(shift: tuple[float, float], period: float, turn_deg: float, tolerance: float = 0.3) -> bool:
    """Whether ``shift`` (rows, cols) is a translation of the checker lattice of :func:`woven_photo` (u + v even)."""
    a = np.deg2rad(turn_deg)
    u = (shift[1] * np.cos(a) + shift[0] * np.sin(a)) / period
    v = (-shift[1] * np.sin(a) + shift[0] * np.cos(a)) / period
    iu, iv = round(u), round(v)
    return abs(u - iu) < tolerance and abs(v - iv) < tolerance and (iu + iv) % 2 == 0


@pytest.mark.parametrize("turn_deg", [0.0, 30.0])
def test_a_woven_photo_repeats_under_its_weave_lattice_not_one_thread(turn_deg):
    repeats = photo_repeats(woven_photo(turn_deg=turn_deg))
    assert len(repeats) == 2
    for r in repeats:
        assert r.correlation > 0.8
        assert lattice_member(r.shift_px, 10.0, turn_deg), r  # the crossings' repeat, two threads along a diagonal
        assert abs(np.hypot(*r.shift_px) - 10.0 * np.sqrt(2)) < 0.5


def test_noise_and_a_flat_photo_do_not_repeat():
    rng = np.random.default_rng(1)
    noise = 0.4 + 0.1 * rng.random((128, 128, 3))
    assert photo_repeats(noise) == []
    assert photo_repeats(np.full((64, 64, 3), 0.3)) == []
    assert MIN_CORRELATION > 0


def test_a_map_that_repeats_with_the_shift_costs_nothing_and_noise_costs_twice_its_variance():
    size, period = 64, 8
    rows, cols = np.mgrid[:size, :size]
    periodic = np.sin(2 * np.pi * cols / period) + np.cos(2 * np.pi * rows / period)
    samples = [shifted_samples(size, (0.0, float(period)), 1.0), shifted_samples(size, (float(period), 0.0), 0.5)]
    assert repeat_penalty_np(periodic, samples) == pytest.approx(0.0, abs=1e-9)
    noise = np.random.default_rng(2).normal(size=(size, size))
    assert repeat_penalty_np(noise, samples) == pytest.approx(1.5 * 2.0, rel=0.1)  # weights 1 + 0.5, E(a - b)^2 = 2


def test_a_fractional_shift_interpolates_and_only_texels_whose_translate_is_on_the_map_count():
    size = 16
    ramp = np.tile(np.arange(size, dtype=float), (size, 1))  # h = column index: a shift of 2.5 columns adds 2.5
    samples = [shifted_samples(size, (0.0, 2.5), 1.0)]
    assert repeat_penalty_np(ramp, samples) == pytest.approx(2.5**2, rel=1e-6)
    assert samples[0].mask.sum() == pytest.approx(1.0)
    assert np.count_nonzero(samples[0].mask) == size * (size - 3)  # columns 0..12 have a translate at most 15


def test_a_photo_shift_scales_to_texels_of_the_overhanging_map():
    assert texel_shift(Repeat((10.0, -5.0), 0.9), 212, 200, 0.06) == pytest.approx((10.0, -5.0))
    assert texel_shift(Repeat((10.0, 0.0), 0.9), 106, 200, 0.06) == pytest.approx((5.0, 0.0))


def test_repeat_samples_records_the_translations_or_why_there_are_none():
    samples, record = repeat_samples(woven_photo(), 64, 0.06)
    assert len(samples) == len(record["repeats"]) == 2 and "repeats under 2" in record["reason"]
    none, record = repeat_samples(np.full((64, 64, 3), 0.3), 64, 0.06)
    assert none == [] and record["repeats"] == [] and "does not repeat" in record["reason"]


def test_the_differentiable_penalty_matches_numpy_and_its_gradient_is_finite():
    import drjit as dr

    from clothscope.fit.repeat import on_device, repeat_penalty
    from clothscope.core.runtime import mitsuba_for

    mi = mitsuba_for("llvm_ad_rgb", 1)
    size = 24
    height = np.random.default_rng(4).normal(size=(size, size))
    samples = [shifted_samples(size, (3.3, -4.6), 0.7), shifted_samples(size, (5.0, 2.0), 0.4)]
    latent = mi.Float(height.ravel().astype(np.float32))
    dr.enable_grad(latent)
    value = repeat_penalty(mi, latent, on_device(mi, samples))
    assert float(value[0]) == pytest.approx(repeat_penalty_np(height, samples), rel=1e-4)
    dr.backward(value)
    gradient = np.array(dr.grad(latent))
    assert np.all(np.isfinite(gradient)) and np.abs(gradient).max() > 0
