"""The capture-realistic field set: draws, weaves, camera footprint, yarn colours and one small render."""
from __future__ import annotations

import io
import json
from dataclasses import replace

import numpy as np
import pytest
from conftest import SCHEMAS, decode, non_finite_outputs
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from clothscope.core.config import schema_defaults
from clothscope.core.schema import load_schema
from clothscope.core.truth import truth_paths
from clothscope.synth.fabrics import TWILL21, TWILL31
from clothscope.synth.field import (
    CAPTURES,
    FIELD_FABRICS,
    FOOTPRINT_HALF,
    CaptureRange,
    FieldHeight,
    draw_field,
    field_index,
    field_rng,
    footprint_half_width,
    save_field,
    synthesize_field,
)


def test_draws_are_reproducible_and_independent():
    first = draw_field("twill", field_rng(3, "twill", 0))
    assert first == draw_field("twill", field_rng(3, "twill", 0))
    assert first != draw_field("twill", field_rng(3, "twill", 1))
    assert first != draw_field("twill", field_rng(4, "twill", 0))


def test_a_subset_of_classes_indexes_the_same_images_and_the_schema_knows_every_class():
    subset = field_index(4, ["satin", "broadcloth"])
    assert subset == [entry for entry in field_index(4) if entry[0] in ("broadcloth", "satin")]
    with pytest.raises(ValueError, match="unknown field class 'denim'"):
        field_index(2, ["twill", "denim"])
    schema = load_schema(SCHEMAS / "config.schema.yaml")["properties"]["synthesize"]["properties"]["field"]["properties"]["classes"]
    assert schema["items"]["enum"] == list(FIELD_FABRICS)


def test_a_capture_range_draws_only_its_captures_and_thread_counts():
    macro = CaptureRange(("macro_ring", "macro_coaxial"), (12.0, 48.0))
    draws = [draw_field(fabric, field_rng(5, fabric, k), macro) for fabric, k, _ in field_index(10, ["broadcloth", "twill"])]
    assert {d.capture for d in draws} == {"macro_ring", "macro_coaxial"}
    assert all(12 <= d.resolution / d.period_px <= 48 for d in draws)
    assert draw_field("satin", field_rng(5, "satin", 0)) == draw_field("satin", field_rng(5, "satin", 0), CaptureRange())
    assert CaptureRange.from_settings({"captures": [], "threads_across": []}) == CaptureRange()
    schema = load_schema(SCHEMAS / "config.schema.yaml")["properties"]["synthesize"]["properties"]["field"]["properties"]
    assert schema["captures"]["items"]["enum"] == list(CAPTURES)
    with pytest.raises(ValueError, match="captures must name"):
        CaptureRange(("phone_selfie",))
    with pytest.raises(ValueError, match="0 < low < high"):
        CaptureRange(threads_across=(48.0, 12.0))
    with pytest.raises(ValueError, match="leaves no period"):
        draw_field("twill", field_rng(5, "twill", 0), CaptureRange(threads_across=(1.0, 2.0)))


def test_index_covers_nine_classes_and_draws_stay_in_their_ranges():
    index = field_index(3)
    assert len(index) == 27 and {f for f, _, _ in index} == set(FIELD_FABRICS) >= {"twill", "linen", "satin"}
    draws = [draw_field(fabric, field_rng(0, fabric, k)) for fabric, k, _ in field_index(12)]
    assert {d.capture for d in draws} == set(CAPTURES)
    for d in draws:
        assert 1024 <= d.resolution <= 2048 and 60 <= d.jpeg_quality <= 95
        if FIELD_FABRICS[d.fabric].periodic:
            assert 3.0 <= d.period_px <= 60.0 and 12 <= d.resolution / d.period_px <= 341
        if d.capture.startswith("phone"):
            assert 60 <= d.fov_deg <= 75
    assert {d.weave_variant for d in draws if d.fabric == "twill"} == {"twill21", "twill31"}


@pytest.mark.parametrize("pattern,floats", [(TWILL21, 2), (TWILL31, 3)])
def test_twills_float_the_warp_and_step_one_thread_per_row(pattern, floats):
    assert (pattern.sum(axis=1) == floats).all()
    for row in range(1, pattern.shape[0]):
        assert np.array_equal(pattern[row], np.roll(pattern[row - 1], 1))


@settings(max_examples=40, deadline=None)
@given(st.floats(8, 75), st.floats(0, 20), st.floats(0, 360))
def test_the_view_stays_on_the_cloth(fov, tilt, axis):
    distance = FOOTPRINT_HALF / footprint_half_width(fov, tilt, axis)
    assert distance > 0
    assert footprint_half_width(fov, tilt, axis) * distance == pytest.approx(FOOTPRINT_HALF)


def test_denim_has_indigo_warp_on_top_and_ecru_weft_below():
    rng = field_rng(0, "twill", 0)
    draw = replace(draw_field("twill", rng), weave_variant="twill31", colour_scheme="two_colour", dyes=("indigo", "ecru"), hairiness=0.0)
    field = FieldHeight(FIELD_FABRICS["twill"], draw, 0.05, rng, 512)
    x, y = np.meshgrid(np.linspace(-0.5, 0.5, 200), np.linspace(-0.5, 0.5, 200))
    colour = field.colour(x, y)
    _, _, warp_on_top = field.layers(x, y)
    assert np.allclose(colour[warp_on_top], field.dyes[0]) and np.allclose(colour[~warp_on_top], field.dyes[1])
    assert 0.65 < warp_on_top.mean() < 0.85  # a 3/1 warp-faced twill shows mostly warp


def test_small_render_decodes_with_consistent_truth(tmp_path):
    photo = synthesize_field("linen", 0, 11, spp=2, max_mesh_resolution=512, variant=schema_defaults()["variant"], threads=1,
                             scale=0.125)
    path = tmp_path / "linen" / "linen_00.jpg"
    save_field(photo, path)
    image = decode(path).rgb
    side = photo.truth["image_resolution"]
    assert image.shape[:2] == (side, side) and side == round(photo.truth["draw"]["resolution"])
    assert Image.open(io.BytesIO(photo.jpeg)).format == "JPEG"
    truth = json.loads(truth_paths(path)["json"].read_text())
    assert truth["fabric_class"] == "linen" and truth["draw"]["slub"] > 0
    assert truth["thread_period_px"] == pytest.approx(truth["thread_period_world"] * side / truth["view_width_world"])
    normal = np.asarray(Image.open(truth_paths(path)["normal"]))
    assert normal.shape[:2] == (side, side)
    assert np.isfinite(image).all() and 0.02 < image.mean() < 0.9
    assert non_finite_outputs(tmp_path) == []
