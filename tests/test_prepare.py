"""Decoding of every supported format, sRGB handling, crop/resize, clipping, and rejections."""
from __future__ import annotations

import json

import numpy as np
import pytest
from conftest import broken_and_valid_files, gradient_rgb
from PIL import Image

from clothscope.atomic import atomic_dir, write_json
from clothscope.imageio import ImageRejected, decode_image, linear_to_srgb, srgb_to_linear
from clothscope.prepare import PrepareSettings, prepare_image, to_working_resolution


def test_srgb_round_trip_and_known_values():
    x = np.linspace(0, 1, 1001, dtype=np.float32)
    assert np.allclose(linear_to_srgb(srgb_to_linear(x)), x, atol=1e-5)
    assert srgb_to_linear(np.array([0.5]))[0] == pytest.approx(0.21404, abs=1e-4)


def test_png8_decodes_to_linear(tmp_path):
    rgb = gradient_rgb()
    Image.fromarray(rgb).save(tmp_path / "a.png")
    decoded = decode_image(tmp_path / "a.png")
    assert decoded.rgb.shape == rgb.shape and decoded.bit_depth == 8
    assert np.allclose(decoded.rgb, srgb_to_linear(rgb / 255.0), atol=1e-6)


def test_png16_gray_and_colour_keep_16_bit_precision(tmp_path):
    from clothscope.imageio import _mitsuba_scalar

    values = np.linspace(0, 65535, 96 * 128).reshape(96, 128).astype(np.uint16)
    Image.fromarray(values).save(tmp_path / "g.png")
    gray = decode_image(tmp_path / "g.png")
    assert gray.bit_depth == 16 and np.allclose(gray.rgb[..., 0], srgb_to_linear(values / 65535.0), atol=1e-6)
    mi = _mitsuba_scalar()
    encoded = np.random.default_rng(0).random((80, 90, 3)).astype(np.float32)
    bitmap = mi.Bitmap(encoded, mi.Bitmap.PixelFormat.RGB).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt16, srgb_gamma=False)
    bitmap.set_srgb_gamma(True)
    bitmap.write(str(tmp_path / "c.png"))
    colour = decode_image(tmp_path / "c.png")
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
    decoded = decode_image(tmp_path / name)
    assert decoded.rgb.shape == (96, 128, 3) and np.all(np.isfinite(decoded.rgb))
    tolerance = 0.06 if mode in ("CMYK", "P") else 0.02
    assert np.abs(decoded.rgb - reference).mean() < tolerance
    if mode == "RGBA":
        assert "alpha channel ignored" in decoded.notes


def test_exr_is_read_as_linear(tmp_path):
    from clothscope.imageio import write_exr

    data = np.random.default_rng(1).random((70, 80, 3)).astype(np.float32) * 3
    write_exr(tmp_path / "x.exr", data)
    decoded = decode_image(tmp_path / "x.exr")
    assert decoded.bit_depth == 32 and np.array_equal(decoded.rgb, data) and not decoded.clipped.any()


def test_exif_orientation_is_applied(tmp_path):
    rgb = np.zeros((80, 120, 3), np.uint8)
    rgb[:10, :10] = 255  # marker at top-left of the stored pixels
    exif = Image.Exif()
    exif[0x0112] = 6  # stored rotated: display needs 90 degrees clockwise
    Image.fromarray(rgb).save(tmp_path / "o.jpg", exif=exif, quality=98)
    decoded = decode_image(tmp_path / "o.jpg")
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


def test_saturated_pixels_are_marked(tmp_path):
    rgb = gradient_rgb()
    rgb[:20, :20] = 255
    Image.fromarray(rgb).save(tmp_path / "s.png")
    assert decode_image(tmp_path / "s.png").clipped[:20, :20].all()


def test_every_broken_file_is_rejected_with_one_line(tmp_path):
    for stem, (path, valid) in broken_and_valid_files(tmp_path).items():
        if valid:
            assert np.all(np.isfinite(decode_image(path).rgb)), stem
            continue
        with pytest.raises(ImageRejected) as err:
            decode_image(path)
        message = str(err.value)
        assert message.startswith(str(path)) and "\n" not in message, message
        if stem == "huge":
            assert "12000x9000" in message and "max_megapixels" in message


def test_prepare_image_accepts_and_rejects(tmp_path):
    files = broken_and_valid_files(tmp_path / "in")
    settings = PrepareSettings(working_resolution=32)
    good = prepare_image("good", files["good"][0], tmp_path / "out" / "good", settings)
    assert good["status"] == "accepted"
    assert sorted(p.name for p in (tmp_path / "out" / "good").iterdir()) == ["clipped.png", "image.exr", "preview.png", "status.json"]
    bad = prepare_image("text", files["text"][0], tmp_path / "out" / "text", settings)
    assert bad["status"] == "rejected" and "text.png" in bad["reason"]
    assert [p.name for p in (tmp_path / "out" / "text").iterdir()] == ["status.json"]
    assert json.loads((tmp_path / "out" / "text" / "status.json").read_text())["status"] == "rejected"


def test_mostly_clipped_image_is_rejected(tmp_path):
    Image.new("RGB", (128, 128), (255, 255, 255)).save(tmp_path / "white.png")
    record = prepare_image("white", tmp_path / "white.png", tmp_path / "out", PrepareSettings())
    assert record["status"] == "rejected" and "clipped" in record["reason"]


def test_outputs_are_atomic(tmp_path):
    with pytest.raises(RuntimeError):
        with atomic_dir(tmp_path / "job") as tmp:
            (tmp / "half.txt").write_text("partial")
            raise RuntimeError("interrupted")
    assert not (tmp_path / "job").exists() and list(tmp_path.iterdir()) == []
    with pytest.raises(ValueError, match="non-finite"):
        write_json(tmp_path / "x.json", {"a": [1.0, float("nan")]})
    assert not (tmp_path / "x.json").exists()
