"""Decoding of every supported format, sRGB handling, crop/resize, clipping, and rejections."""
from __future__ import annotations

import dataclasses
import json
import tracemalloc
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import FILE_PROBLEMS, broken_and_valid_files, decode, gradient_rgb
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image

from clothscope.core.atomic import atomic_dir, write_json
from clothscope.core.config import settings as config_settings
from clothscope.core.imageio import ImageRejected, header_size, linear_to_srgb, read_exr, srgb_to_linear, write_exr
from clothscope.core.schema import InputError
from clothscope.features.structure import StructureSettings
from clothscope.prepare.image import prepare_image, prepare_memory_mb, to_working_resolution


def test_srgb_round_trip_and_known_values():
    x = np.linspace(0, 1, 1001, dtype=np.float32)
    assert np.allclose(linear_to_srgb(srgb_to_linear(x)), x, atol=1e-5)
    assert srgb_to_linear(np.array([0.5]))[0] == pytest.approx(0.21404, abs=1e-4)


def test_png8_decodes_to_linear(tmp_path):
    rgb = gradient_rgb()
    Image.fromarray(rgb).save(tmp_path / "a.png")
    decoded = decode(tmp_path / "a.png")
    assert decoded.rgb.shape == rgb.shape and decoded.bit_depth == 8
    assert np.allclose(decoded.rgb, srgb_to_linear(rgb / 255.0), atol=1e-6)


def test_png16_gray_and_colour_keep_16_bit_precision(tmp_path):
    from clothscope.core.imageio import _mitsuba_scalar

    values = np.linspace(0, 65535, 96 * 128).reshape(96, 128).astype(np.uint16)
    Image.fromarray(values).save(tmp_path / "g.png")
    gray = decode(tmp_path / "g.png")
    assert gray.bit_depth == 16 and np.allclose(gray.rgb[..., 0], srgb_to_linear(values / 65535.0), atol=1e-6)
    mi = _mitsuba_scalar()
    encoded = np.random.default_rng(0).random((80, 90, 3)).astype(np.float32)
    bitmap = mi.Bitmap(encoded, mi.Bitmap.PixelFormat.RGB).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt16, srgb_gamma=False)
    bitmap.set_srgb_gamma(True)
    bitmap.write(str(tmp_path / "c.png"))
    colour = decode(tmp_path / "c.png")
    assert colour.bit_depth == 16
    assert np.abs(colour.rgb - srgb_to_linear(encoded)).max() < 2e-4  # 8-bit decoding would be off by ~2e-3


@pytest.mark.parametrize("name, mode, kwargs", [("a.jpg", "RGB", {"quality": 98}), ("g.jpg", "L", {"quality": 98}),
                                                ("c.jpg", "CMYK", {"quality": 98}), ("t.tif", "RGB", {}),
                                                ("t16.tif", "I;16", {}), ("p.png", "P", {}), ("a.png", "RGBA", {})])
def test_common_formats_decode_to_similar_linear_rgb(tmp_path, name, mode, kwargs):
    rgb = gradient_rgb()
    reference = srgb_to_linear(rgb / 255.0)
    image = Image.fromarray(rgb)
    if mode == "I;16":
        image = Image.fromarray(rgb[..., 0].astype(np.uint16) * 257)
        reference = np.repeat(reference[..., :1], 3, axis=2)
    elif mode == "L":
        image = image.convert("L")
        reference = srgb_to_linear(np.repeat(np.asarray(image)[..., None] / 255.0, 3, axis=2))
    elif mode != "RGB":
        image = image.convert(mode)
    image.save(tmp_path / name, **kwargs)
    decoded = decode(tmp_path / name)
    assert decoded.rgb.shape == (96, 128, 3) and np.all(np.isfinite(decoded.rgb))
    tolerance = 0.06 if mode in ("CMYK", "P") else 0.02
    assert np.abs(decoded.rgb - reference).mean() < tolerance
    if mode == "RGBA":
        assert "alpha channel ignored" in decoded.notes


def test_exr_is_read_as_linear(tmp_path):
    from clothscope.core.imageio import write_exr

    data = np.random.default_rng(1).random((70, 80, 3)).astype(np.float32) * 3
    write_exr(tmp_path / "x.exr", data)
    decoded = decode(tmp_path / "x.exr")
    assert decoded.bit_depth == 32 and np.array_equal(decoded.rgb, data) and not decoded.clipped.any()


def test_exif_orientation_is_applied(tmp_path):
    rgb = np.zeros((80, 120, 3), np.uint8)
    rgb[:10, :10] = 255  # marker at top-left of the stored pixels
    exif = Image.Exif()
    exif[0x0112] = 6  # stored rotated: display needs 90 degrees clockwise
    Image.fromarray(rgb).save(tmp_path / "o.jpg", exif=exif, quality=98)
    decoded = decode(tmp_path / "o.jpg")
    assert decoded.rgb.shape[:2] == (120, 80)
    assert decoded.rgb[:10, -10:].mean() > 0.8 and decoded.rgb[:10, :10].mean() < 0.1
    assert any("orientation 6" in note for note in decoded.notes)


def test_crop_resize_and_clipped_mask():
    rgb = np.full((300, 400, 3), 0.2, np.float32)
    clipped = np.zeros((300, 400), bool)
    clipped[0:3, 50:53] = True  # inside the centred square, which starts at column 50
    out, mask = to_working_resolution(rgb, clipped, 64)
    assert out.shape == (64, 64, 3) and np.allclose(out, 0.2, atol=1e-5)
    assert mask[0, 0] and mask.sum() == 1


def test_a_magnified_clipped_mask_marks_only_the_pixels_under_a_clipped_one():
    rgb = np.full((64, 64, 3), 0.2, np.float32)
    clipped = np.zeros((64, 64), bool)
    clipped[10, 20] = clipped[40, 41] = True
    out, mask = to_working_resolution(rgb, clipped, 256)
    assert np.allclose(out, 0.2, atol=1e-5)
    assert mask.sum() == 2 * 16 and mask[40:44, 80:84].all() and mask[160:164, 164:168].all()


def test_saturated_pixels_are_marked(tmp_path):
    rgb = gradient_rgb()
    rgb[:20, :20] = 255
    Image.fromarray(rgb).save(tmp_path / "s.png")
    assert decode(tmp_path / "s.png").clipped[:20, :20].all()


def test_every_broken_file_is_rejected_with_one_line(tmp_path):
    for stem, (path, valid) in broken_and_valid_files(tmp_path).items():
        if valid:
            assert np.all(np.isfinite(decode(path).rgb)), stem
            continue
        with pytest.raises(ImageRejected) as err:
            decode(path)
        message = str(err.value)
        assert message.startswith(str(path)) and "\n" not in message, message
        if stem == "huge":
            assert "12000x9000" in message and "max_megapixels" in message
        if stem in FILE_PROBLEMS:
            assert FILE_PROBLEMS[stem] in message, message


def test_prepare_image_accepts_and_rejects(tmp_path):
    files = broken_and_valid_files(tmp_path / "in")
    settings = config_settings("prepare", working_resolution=32, scale="frame")
    good = prepare_image("good", files["good"][0], tmp_path / "out" / "good", settings)
    assert good["status"] == "accepted"
    assert sorted(p.name for p in (tmp_path / "out" / "good").iterdir()) == ["clipped.png", "image.exr", "preview.png", "status.json"]
    bad = prepare_image("text", files["text"][0], tmp_path / "out" / "text", settings)
    assert bad["status"] == "rejected" and "text.png" in bad["reason"]
    assert [p.name for p in (tmp_path / "out" / "text").iterdir()] == ["status.json"]
    assert json.loads((tmp_path / "out" / "text" / "status.json").read_text())["status"] == "rejected"


def test_mostly_clipped_image_is_rejected(tmp_path):
    Image.new("RGB", (128, 128), (255, 255, 255)).save(tmp_path / "white.png")
    record = prepare_image("white", tmp_path / "white.png", tmp_path / "out", config_settings("prepare", scale="frame"))
    assert record["status"] == "rejected" and "clipped" in record["reason"]


def test_a_frame_without_thread_scale_texture_is_rejected_and_fine_pile_is_not(tmp_path):
    """Black, uniform and smoothly shaded frames hold nothing to fit or classify; velvet's fine pile does."""
    from conftest import SYNTHETIC

    settings = config_settings("prepare", scale="frame")
    ramp = np.tile(np.linspace(20, 230, 512), (512, 1)).astype(np.uint8)
    frames = {"black": np.zeros((300, 300, 3), np.uint8), "grey": np.full((300, 300, 3), 128, np.uint8),
              "ramp": np.stack([ramp] * 3, axis=-1)}
    for name, pixels in frames.items():
        Image.fromarray(pixels).save(tmp_path / f"{name}.png")
        record = prepare_image(name, tmp_path / f"{name}.png", tmp_path / "out" / name, settings)
        assert record["status"] == "rejected" and record["reason"].startswith(f"{tmp_path / name}.png: no thread-scale texture")
        assert "prepare.min_detail" in record["reason"] and "\n" not in record["reason"]
    velvet = prepare_image("velvet", SYNTHETIC / "velvet" / "velvet_green.png", tmp_path / "out" / "velvet", settings)
    assert velvet["status"] == "accepted" and velvet["thread_detail"] > 2 * settings.min_detail


def test_outputs_are_atomic(tmp_path):
    with pytest.raises(RuntimeError):
        with atomic_dir(tmp_path / "job") as tmp:
            (tmp / "half.txt").write_text("partial")
            raise RuntimeError("interrupted")
    assert not (tmp_path / "job").exists() and list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match="non-finite"):
        write_json(tmp_path / "x.json", {"a": [1.0, float("nan")]})
    assert not (tmp_path / "x.json").exists()


def test_a_rerun_removes_what_a_killed_writer_left_and_nothing_else(tmp_path):
    """A SIGKILLed job leaves .<name>.<random>.tmp behind; the next writer of that target removes it."""
    import tempfile

    from clothscope.core.atomic import stale_temporaries, write_text

    stale_dir = Path(tempfile.mkdtemp(prefix=".normals.", suffix=".tmp", dir=tmp_path))
    (stale_dir / "half.exr").write_text("partial")
    stale_file = Path(tempfile.mkstemp(prefix=".state.json.", suffix=".tmp.json", dir=tmp_path)[1])
    neighbour = Path(tempfile.mkdtemp(prefix=".normals.v2.", suffix=".tmp", dir=tmp_path))  # another target's writer
    assert stale_temporaries(tmp_path / "normals") == [stale_dir]
    with atomic_dir(tmp_path / "normals") as tmp:
        (tmp / "normal.exr").write_text("whole")
    write_text(tmp_path / "state.json", "{}")
    assert not stale_dir.exists() and not stale_file.exists() and neighbour.is_dir()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([neighbour.name, "normals", "state.json"])


LATTICE = StructureSettings(border=0.1, peak_threshold=10.0, fundamental_fraction=0.3, lbp_scale="pixels")


def weave_photo(side: int, period: float, angle_deg: float = 20.0, seed: int = 0) -> np.ndarray:
    """8-bit RGB of a plain-weave-like relief (yarns ``period`` px apart, crossings between), turned by ``angle_deg``, with noise."""
    rng = np.random.default_rng(seed)
    rows, cols = np.mgrid[0:side, 0:side].astype(np.float64)
    a = np.deg2rad(angle_deg)
    u, v = (cols * np.cos(a) + rows * np.sin(a)) / period, (-cols * np.sin(a) + rows * np.cos(a)) / period
    relief = 0.6 * (np.cos(2 * np.pi * u) + 0.8 * np.cos(2 * np.pi * v)) + 0.5 * np.cos(2 * np.pi * u) * np.cos(2 * np.pi * v)
    grey = 0.45 + 0.2 * relief + 0.03 * rng.standard_normal(relief.shape)
    return np.repeat(np.clip(grey * 255, 0, 255).astype(np.uint8)[..., None], 3, axis=-1)


@pytest.mark.parametrize("side, period", [(1024, 20.0), (900, 14.0), (1200, 30.0)])
def test_native_period_is_measured_at_native_resolution(side, period):
    from clothscope.core.imageio import srgb_to_linear
    from clothscope.prepare.image import native_period

    rgb = srgb_to_linear(weave_photo(side, period) / 255.0)
    assert native_period(rgb, 1024, LATTICE) == pytest.approx(period, rel=0.05)


def test_yarn_dyed_stripes_do_not_read_as_the_thread_period():
    from clothscope.core.imageio import srgb_to_linear
    from clothscope.prepare.image import native_period

    grey = srgb_to_linear(weave_photo(1024, 12.0) / 255.0)[..., :1]
    warp_band = (np.arange(1024) // 96) % 2 == 1  # stripes of 8 threads, red and ecru
    rgb = grey * np.where(warp_band[None, :, None], [0.62, 0.58, 0.48], [0.55, 0.05, 0.05]) / 0.6
    for peak in ("weighted", "strongest"):
        assert native_period(rgb, 1024, LATTICE, "shading", peak) == pytest.approx(12.0, rel=0.05)
    assert native_period(rgb, 1024, LATTICE, "luminance", "strongest") != pytest.approx(12.0, rel=0.05)


@pytest.mark.parametrize("step", [0.04, 0.08])
def test_stripes_of_two_shades_of_one_hue_do_not_read_as_the_thread_period(step):
    """Two shades of one grey share a chromaticity, so the shading keeps their stripes; the weighted peak still reads the threads."""
    from scipy import ndimage

    from clothscope.core.imageio import srgb_to_linear
    from clothscope.prepare.image import native_period

    grey = srgb_to_linear(weave_photo(1024, 12.0) / 255.0)[..., :1]
    shade = ndimage.gaussian_filter1d(np.where((np.arange(1024) // 96) % 2 == 1, 0.1 + step, 0.1), 6.0)  # 8 threads each
    rgb = (0.2 * grey + shade[None, :, None]) * np.array([0.45, 0.45, 0.5])
    assert native_period(rgb, 1024, LATTICE, "shading", "weighted") == pytest.approx(12.0, rel=0.05)
    assert native_period(rgb, 1024, LATTICE, "shading", "strongest") == pytest.approx(192.0, rel=0.05)  # the repeat


def twill_photo(side: int, period: float, angle_deg: float = 20.0, seed: int = 0) -> np.ndarray:
    """Linear RGB of a 2/2 twill: yarns ``period`` px apart, each crossing showing the warp or the weft on top, and the
    floats' diagonal rib (2 sqrt(2) periods apart) shaded on top."""
    from clothscope.core.imageio import srgb_to_linear

    rng = np.random.default_rng(seed)
    rows, cols = np.mgrid[0:side, 0:side].astype(np.float64)
    a = np.deg2rad(angle_deg)
    u, v = (cols * np.cos(a) + rows * np.sin(a)) / period, (-cols * np.sin(a) + rows * np.cos(a)) / period
    warp_on_top = ((np.floor(u) - np.floor(v)) % 4) < 2
    relief = np.sqrt(np.sin(np.pi * np.where(warp_on_top, u % 1.0, v % 1.0))) + 0.3 * np.cos(2 * np.pi * (u - v) / 4)
    grey = 0.3 + 0.2 * relief + 0.02 * rng.standard_normal(relief.shape)
    return srgb_to_linear(np.repeat(np.clip(grey, 0, 1)[..., None], 3, axis=-1))


@pytest.mark.parametrize("angle_deg", [20.0, -35.0])
def test_the_yarn_axes_read_the_threads_where_a_twill_rib_outshines_them(angle_deg):
    from clothscope.features.structure import analysis_field
    from clothscope.prepare.image import native_period, yarn_axes

    rgb = twill_photo(1024, 12.0, angle_deg)
    assert native_period(rgb, 1024, LATTICE, "shading", "weighted") == pytest.approx(12.0 * 2 * np.sqrt(2), rel=0.05)
    assert native_period(rgb, 1024, LATTICE, "shading", "axes") == pytest.approx(12.0, rel=0.05)
    assert native_period(rgb, 1024, LATTICE, "shading", "axes_harmonic") == pytest.approx(12.0, rel=0.05)
    axes = yarn_axes(analysis_field(rgb[..., 1], 0.0))
    assert axes.strength > 0.1
    assert abs((np.rad2deg(axes.angle) - angle_deg + 45) % 90 - 45) < 5  # an axis along the yarns, modulo 90 degrees


def test_without_clear_yarn_axes_the_axes_pick_is_the_weighted_one():
    from clothscope.features.structure import analysis_field
    from clothscope.prepare.image import YarnAxes, native_lattice, period_peak_index, yarn_axes

    noise = np.random.default_rng(1).standard_normal((256, 256))
    assert yarn_axes(analysis_field(noise, 0.0)).strength < 0.05
    assert yarn_axes(np.zeros((64, 64))) == YarnAxes(0.0, 0.0)
    native = native_lattice(twill_photo(1024, 12.0), 1024, LATTICE)
    peaks = native.found.peaks
    weak = YarnAxes(native.axes.angle, 0.05)
    assert period_peak_index(native.spectrum, peaks, "axes", weak) == period_peak_index(native.spectrum, peaks, "weighted")
    assert period_peak_index(native.spectrum, peaks, "axes", native.axes) != period_peak_index(native.spectrum, peaks, "weighted")
    with pytest.raises(ValueError, match="needs the yarn axes"):
        period_peak_index(native.spectrum, peaks, "axes")


def crossings_photo(side: int, period: float, angle_deg: float, seed: int = 0) -> np.ndarray:
    """Linear RGB of yarn crossings lit from the lens: a round bright dome (Gaussian, 0.1 period wide) at every crossing
    of a square lattice ``period`` px apart, whose (1, 1) harmonic has the most power times frequency."""
    from clothscope.core.imageio import srgb_to_linear

    rows, cols = np.mgrid[0:side, 0:side].astype(np.float64)
    a = np.deg2rad(angle_deg)
    u, v = (cols * np.cos(a) + rows * np.sin(a)) / period, (-cols * np.sin(a) + rows * np.cos(a)) / period
    dome = np.exp(-((u % 1.0 - 0.5) ** 2 + (v % 1.0 - 0.5) ** 2) / (2 * 0.1**2))
    grey = 0.25 + 0.4 * dome + 0.02 * np.random.default_rng(seed).standard_normal(dome.shape)
    return srgb_to_linear(np.repeat(np.clip(grey, 0, 1)[..., None], 3, axis=-1))


@pytest.mark.parametrize("angle_deg", [20.0, -35.0])
def test_without_yarn_axes_a_harmonic_of_round_crossings_steps_down_to_the_threads(angle_deg):
    from clothscope.prepare.image import (
        AXES_MIN_STRENGTH,
        native_lattice,
        native_period,
        period_peak_index,
        threads_below_harmonic,
    )

    rgb = crossings_photo(1024, 16.0, angle_deg)
    native = native_lattice(rgb, 1024, LATTICE)
    assert native.axes.strength < AXES_MIN_STRENGTH  # round domes: no yarn direction in the gradients
    for peak in ("weighted", "axes"):
        assert native_period(rgb, 1024, LATTICE, "shading", peak) == pytest.approx(16.0 / np.sqrt(2), rel=0.05)
    assert native_period(rgb, 1024, LATTICE, "shading", "axes_harmonic") == pytest.approx(16.0, rel=0.05)
    s, peaks = native.spectrum, native.found.peaks
    pick = period_peak_index(s, peaks, "weighted")
    assert threads_below_harmonic(s, peaks, pick) != pick
    assert threads_below_harmonic(s, peaks, pick, min_power=100.0) == pick  # the threads' peak is not that strong


def ribbed_photo(side: int, period: float, harmonic: int, share: float, seed: int = 0) -> np.ndarray:
    """Linear RGB of threads ``period`` px apart along two axes at 20 degrees, each with its ``harmonic``-th harmonic at
    ``share`` of its amplitude, under noise strong enough that the gradients show no yarn axes."""
    from clothscope.core.imageio import srgb_to_linear

    rows, cols = np.mgrid[0:side, 0:side].astype(np.float64)
    a = np.deg2rad(20.0)
    u, v = (cols * np.cos(a) + rows * np.sin(a)) / period, (-cols * np.sin(a) + rows * np.cos(a)) / period
    relief = sum(np.cos(2 * np.pi * w) + share * np.cos(2 * np.pi * harmonic * w) for w in (u, v))
    grey = 0.4 + 0.05 * relief + 0.1 * np.random.default_rng(seed).standard_normal(u.shape)
    return srgb_to_linear(np.repeat(np.clip(grey, 0, 1)[..., None], 3, axis=-1))


@pytest.mark.parametrize("harmonic", [2, 3, 4])
def test_without_yarn_axes_a_higher_harmonic_steps_down_to_the_threads(harmonic):
    from clothscope.prepare.image import AXES_MIN_STRENGTH, native_lattice, native_period

    rgb = ribbed_photo(1024, 24.0, harmonic, share=0.8)  # the harmonic: 0.64 of the threads' power, m times their frequency
    assert native_lattice(rgb, 1024, LATTICE).axes.strength < AXES_MIN_STRENGTH
    for peak in ("weighted", "axes", "axes_harmonic"):
        assert native_period(rgb, 1024, LATTICE, "shading", peak) == pytest.approx(24.0 / harmonic, rel=0.05)
    assert native_period(rgb, 1024, LATTICE, "shading", "axes_fundamental") == pytest.approx(24.0, rel=0.05)


def test_a_harmonic_stronger_than_the_peak_below_it_is_kept():
    from clothscope.features.structure import refined_radius
    from clothscope.prepare.image import fundamental_below, native_lattice, period_peak_index

    native = native_lattice(ribbed_photo(1024, 24.0, 3, share=1.3), 1024, LATTICE)  # the harmonic: 1.7 times the power
    s, peaks = native.spectrum, native.found.peaks
    pick = period_peak_index(s, peaks, "weighted")
    assert 1024 / refined_radius(s, int(peaks[pick])) == pytest.approx(8.0, rel=0.05)
    assert fundamental_below(s, peaks, pick) == pick
    assert fundamental_below(s, peaks, period_peak_index(s, peaks, "strongest")) == period_peak_index(s, peaks, "strongest")


def test_an_unknown_period_peak_is_refused():
    from clothscope.prepare.image import native_period

    with pytest.raises(ValueError, match="period_peak must be one of"):
        native_period(np.full((128, 128, 3), 0.5), 128, LATTICE, "shading", "tallest")
    with pytest.raises(ValueError, match="period_peak must be one of"):
        dataclasses.replace(config_settings("prepare"), period_peak="tallest")
    with pytest.raises(InputError, match="prepare.period_peak: 'tallest' is not one of"):
        config_settings("prepare", period_peak="tallest")
    from clothscope.prepare.image import PERIOD_PEAKS

    assert all(config_settings("prepare", period_peak=peak).period_peak == peak for peak in PERIOD_PEAKS)  # schema agrees


def test_thread_scale_crops_fine_threads_into_the_band_and_records_it(tmp_path):
    Image.fromarray(weave_photo(1024, 20.0)).save(tmp_path / "fine.png")
    settings = config_settings("prepare", working_resolution=256, scale="threads")
    record = prepare_image("fine", tmp_path / "fine.png", tmp_path / "out", settings, LATTICE)
    scale = record["scale"]
    assert record["status"] == "accepted" and scale["method"] == "threads"
    assert scale["native_period_px"] == pytest.approx(20.0, rel=0.05)
    assert 256 < scale["crop_px"] < 1024
    assert settings.period_band[0] <= scale["working_period_px"] <= settings.period_band[1]
    assert scale["native_px_per_working_px"] == pytest.approx(scale["crop_px"] / 256)
    assert "note" not in scale
    # the whole frame would have put the threads at 5 px; "frame" keeps it and says nothing about threads
    frame = prepare_image("fine", tmp_path / "fine.png", tmp_path / "frame", config_settings("prepare", working_resolution=256, scale="frame"))
    assert frame["scale"] == {"method": "frame", "crop_px": 1024, "native_px_per_working_px": 4.0}


def test_the_axes_pick_crops_a_twill_by_its_threads_not_its_rib(tmp_path):
    from clothscope.core.imageio import linear_to_srgb

    Image.fromarray(np.clip(linear_to_srgb(twill_photo(1024, 12.0)) * 255 + 0.5, 0, 255).astype(np.uint8)).save(
        tmp_path / "twill.png")
    scales = {peak: prepare_image("twill", tmp_path / "twill.png", tmp_path / peak, config_settings(
        "prepare", working_resolution=256, scale="threads", period_peak=peak), LATTICE)["scale"] for peak in ("weighted", "axes")}
    assert scales["weighted"]["native_period_px"] == pytest.approx(12.0 * 2 * np.sqrt(2), rel=0.05)  # the rib
    assert scales["weighted"]["crop_px"] == 1024  # the rib lands in the band: the threads would be 3 px wide
    assert scales["axes"]["native_period_px"] == pytest.approx(12.0, rel=0.05)
    assert 8.0 <= scales["axes"]["working_period_px"] <= 16.0 and scales["axes"]["crop_px"] < 1024


def test_thread_scale_keeps_the_frame_when_threads_are_coarse_or_absent(tmp_path):
    settings = config_settings("prepare", working_resolution=128, scale="threads")
    Image.fromarray(weave_photo(512, 48.0)).save(tmp_path / "coarse.png")
    coarse = prepare_image("coarse", tmp_path / "coarse.png", tmp_path / "coarse", settings, LATTICE)["scale"]
    assert coarse["crop_px"] == 512 and coarse["working_period_px"] == pytest.approx(12.0, rel=0.05)
    noise = np.random.default_rng(3).integers(60, 200, size=(400, 400, 3), dtype=np.uint8)
    Image.fromarray(noise).save(tmp_path / "noise.png")
    plain = prepare_image("noise", tmp_path / "noise.png", tmp_path / "noise", settings, LATTICE)
    assert plain["status"] == "accepted" and plain["scale"]["native_period_px"] is None
    assert plain["scale"]["crop_px"] == 400 and "no thread lattice" in plain["scale"]["note"]
    Image.fromarray(weave_photo(128, 4.0)).save(tmp_path / "tiny.png")
    tiny = prepare_image("tiny", tmp_path / "tiny.png", tmp_path / "tiny", settings, LATTICE)["scale"]
    assert tiny["crop_px"] == 128 and "photograph closer" in tiny["note"]  # never upsampled


def test_fine_threads_are_magnified_into_the_band_up_to_max_upsample(tmp_path):
    Image.fromarray(weave_photo(256, 7.5)).save(tmp_path / "fine.png")
    twice = config_settings("prepare", working_resolution=256, scale="threads", max_upsample=2.0)
    fine = prepare_image("fine", tmp_path / "fine.png", tmp_path / "fine", twice, LATTICE)
    scale = fine["scale"]
    assert scale["crop_px"] < 256 and scale["native_px_per_working_px"] < 1.0
    assert scale["working_period_px"] == pytest.approx(11.3, rel=0.06) and "note" not in scale
    image = read_exr(tmp_path / "fine" / "image.exr")
    assert image.shape[:2] == (256, 256) and np.isfinite(image).all() and image.min() >= 0.0
    Image.fromarray(weave_photo(256, 4.0)).save(tmp_path / "finer.png")
    finer = prepare_image("finer", tmp_path / "finer.png", tmp_path / "finer", twice, LATTICE)["scale"]
    assert finer["crop_px"] == 128  # at most twice: still below the band
    assert "magnified 2 times: photograph closer" in finer["note"]


def test_thread_scale_needs_the_peak_test_and_a_valid_band(tmp_path):
    with pytest.raises(ValueError, match="lattice"):
        prepare_image("x", tmp_path / "x.png", tmp_path / "out", config_settings("prepare", scale="threads"))
    with pytest.raises(ValueError, match="period_band"):
        config_settings("prepare", period_band=[16.0, 8.0])
    with pytest.raises(ValueError, match="scale"):
        config_settings("prepare", scale="zoom")


@pytest.fixture(scope="module")
def valid_files(tmp_path_factory) -> dict[str, bytes]:
    """The bytes of a small valid PNG, JPEG, TIFF, BMP, WebP and OpenEXR."""
    folder = tmp_path_factory.mktemp("valid")
    rgb = gradient_rgb(48, 64)
    Image.fromarray(rgb).save(folder / "v.png")
    Image.fromarray(rgb).save(folder / "v.jpg", quality=90)
    Image.fromarray(rgb).save(folder / "v.tif")
    Image.fromarray(rgb).save(folder / "v.bmp")
    Image.fromarray(rgb).save(folder / "v.webp", quality=90)
    write_exr(folder / "v.exr", rgb.astype(np.float32) / 255)
    return {suffix: (folder / f"v.{suffix}").read_bytes() for suffix in ("png", "jpg", "tif", "bmp", "webp", "exr")}


MUTATIONS = st.one_of(
    st.tuples(st.just("truncate"), st.floats(0.0, 1.0, exclude_max=True)),
    st.tuples(st.just("flip"), st.lists(st.tuples(st.floats(0.0, 1.0, exclude_max=True), st.integers(0, 7)), min_size=1, max_size=20)),
    st.tuples(st.just("splice"), st.floats(0.0, 1.0, exclude_max=True), st.binary(min_size=1, max_size=64)),
)


def mutated(data: bytes, mutation: tuple) -> bytes:
    """``data`` truncated, with bits flipped, or with random bytes written over part of it."""
    kind, *args = mutation
    if kind == "truncate":
        return data[: int(args[0] * len(data))]
    out = bytearray(data)
    if kind == "flip":
        for where, bit in args[0]:
            out[int(where * len(out))] ^= 1 << bit
    else:
        start = int(args[0] * len(out))
        out[start:start + len(args[1])] = args[1]
    return bytes(out)


@settings(max_examples=120, deadline=10_000, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.sampled_from(["png", "jpg", "tif", "bmp", "webp", "exr"]), MUTATIONS)
def test_fuzzed_files_decode_or_are_rejected_with_one_line(valid_files, tmp_path, suffix, mutation):
    """Truncated, bit-flipped or overwritten PNG, JPEG, TIFF, BMP, WebP and EXR files: finite pixels or one line, never another error."""
    path = tmp_path / f"fuzzed.{suffix}"
    path.write_bytes(mutated(valid_files[suffix], mutation))
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a decoder's warning becomes a note, never a warning on stderr
        try:
            decoded = decode(path, min_px=16)
        except ImageRejected as err:
            assert str(err).startswith(str(path)) and "\n" not in str(err)
        else:
            assert decoded.rgb.ndim == 3 and np.isfinite(decoded.rgb).all()


def test_a_decoder_warning_becomes_one_note_not_a_warning(tmp_path):
    """A TIFF whose description tag claims more bytes than the file holds decodes; Pillow's warning is a note."""
    import io
    import struct

    buffer = io.BytesIO()
    Image.fromarray(gradient_rgb(40, 40)).save(buffer, format="TIFF", description="x" * 64)
    data = bytearray(buffer.getvalue())
    ifd = struct.unpack_from("<I", data, 4)[0]
    for entry in range(struct.unpack_from("<H", data, ifd)[0]):
        offset = ifd + 2 + 12 * entry
        if struct.unpack_from("<H", data, offset)[0] == 270:  # ImageDescription: claim a million bytes
            struct.pack_into("<I", data, offset + 4, 10**6)
    (tmp_path / "damaged_tag.tif").write_bytes(bytes(data))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        decoded = decode(tmp_path / "damaged_tag.tif", min_px=16)
    assert decoded.rgb.shape == (40, 40, 3)
    assert decoded.notes == ["decoder warning: Tag data larger than file. Skipping tag 270"]


def test_decompression_bomb_is_refused_from_the_header(tmp_path):
    """A 108-megapixel PNG of 337 KB is refused before its pixels are allocated (decoded RGB would take over 1 GB)."""
    Image.new("1", (12000, 9000)).save(tmp_path / "bomb.png")
    tracemalloc.start()
    with pytest.raises(ImageRejected, match="12000x9000"):
        decode(tmp_path / "bomb.png")
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 20e6, f"{peak / 1e6:.0f} MB allocated before refusing"


@pytest.mark.parametrize("mode", ["RGB", "L", "P"])
def test_8bit_photos_decode_through_the_table_exactly_as_the_transfer_function(tmp_path, mode):
    from clothscope.core.imageio import srgb_to_linear

    codes = np.random.default_rng(5).integers(0, 256, size=(70, 90, 3), dtype=np.uint8)
    image = Image.fromarray(codes).convert(mode)
    image.save(tmp_path / "photo.png")
    expected = np.asarray(image.convert("RGB"), dtype=np.float32) / 255.0
    decoded = decode(tmp_path / "photo.png", clip_threshold=0.9)
    assert decoded.rgb.dtype == np.float32 and np.array_equal(decoded.rgb, srgb_to_linear(expected))
    assert np.array_equal(decoded.clipped, np.any(expected >= 0.9, axis=2))


def test_the_header_gives_the_size_without_decoding_and_none_for_a_broken_file(tmp_path):
    write_exr(tmp_path / "wide.exr", np.zeros((30, 50, 3), np.float32))
    Image.new("RGB", (40, 20)).save(tmp_path / "wide.jpg")
    (tmp_path / "junk.jpg").write_bytes(b"not an image")
    (tmp_path / "junk.exr").write_bytes(b"\x76\x2f\x31\x01 truncated")
    assert header_size(tmp_path / "wide.exr") == (50, 30)
    assert header_size(tmp_path / "wide.jpg") == (40, 20)
    assert header_size(tmp_path / "junk.jpg") is None and header_size(tmp_path / "junk.exr") is None
    assert header_size(tmp_path / "missing.png") is None


def test_the_prepare_memory_request_grows_with_the_pixels_and_stops_at_the_limit(tmp_path):
    """A large photo asks for more memory than a small one, never more than the size limit allows; a broken one the least."""
    Image.new("RGB", (4000, 3000)).save(tmp_path / "large.jpg")
    Image.new("RGB", (400, 300)).save(tmp_path / "small.jpg")
    (tmp_path / "junk.jpg").write_bytes(b"not an image")
    large, small, junk = (prepare_memory_mb(tmp_path / f"{name}.jpg") for name in ("large", "small", "junk"))
    assert junk <= small < large
    assert small < prepare_memory_mb(tmp_path / "large.jpg", max_megapixels=1.2) < large
    assert prepare_memory_mb(tmp_path / "large.jpg", max_megapixels=0.12) == small  # counted at the limit


def test_16_bit_codes_decode_through_the_table_exactly_as_the_transfer_function(tmp_path):
    """16-bit PNG codes (colour, and grey with alpha) give the values and clipped mask of the float formula, bit for bit."""
    from clothscope.core.imageio import _mitsuba_scalar

    mi = _mitsuba_scalar()
    codes = np.random.default_rng(1).integers(0, 65536, (70, 80, 3), dtype=np.uint16)
    mi.Bitmap(codes, mi.Bitmap.PixelFormat.RGB).write(str(tmp_path / "c.png"))
    mi.Bitmap(codes[..., :2].copy(), mi.Bitmap.PixelFormat.YA).write(str(tmp_path / "ya.png"))
    for name, expected in (("c.png", codes), ("ya.png", np.repeat(codes[..., :1], 3, axis=2))):
        decoded = decode(tmp_path / name)
        encoded = expected.astype(np.float32) / 65535.0
        assert decoded.bit_depth == 16 and decoded.rgb.shape == (70, 80, 3)
        assert np.array_equal(decoded.rgb, srgb_to_linear(encoded))
        assert np.array_equal(decoded.clipped, np.any(encoded >= 0.98, axis=2))
