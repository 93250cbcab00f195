"""Colour model of the normal-map fit (clothscope.fit.colour): one colour, or the photo's dye layout."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from clothscope.core.imageio import read_png, srgb_to_linear
from clothscope.fit.colour import (
    DARK_LUMINANCE,
    VALLEY_FRACTION,
    ColourModel,
    choose_colour_model,
    dye_colours,
    layout_texture,
    mixed_colours,
    texel_samples,
    valley_ratio,
)
from clothscope.prepare.shading import chromaticity, dye_groups


def two_dye_photo(size: int = 64, first: tuple[float, float, float] = (0.55, 0.05, 0.05)) -> np.ndarray:
    """Stripes of ``first`` (red) and ecru 8 px wide along the columns, with a thread relief."""
    y, x = np.mgrid[:size, :size].astype(float)
    relief = 0.75 + 0.2 * np.cos(2 * np.pi * x / 4) * np.cos(2 * np.pi * y / 4)
    dye = np.where(((x // 8) % 2 == 1)[..., None], [0.62, 0.58, 0.48], list(first))
    return relief[..., None] * dye


def test_texels_map_onto_the_view_with_the_overhang_extending_the_edge_groups():
    groups = np.zeros((4, 4), dtype=int)
    groups[:, 2:] = 1
    texels = texel_samples(groups, 8, 0.0)
    assert np.array_equal(texels, np.repeat(np.repeat(groups, 2, axis=0), 2, axis=1))
    wide = texel_samples(groups, 10, 0.5)  # the plane is 1.5 views wide: its outer texels take the edge groups
    assert np.all(wide[:, 0] == 0) and np.all(wide[:, -1] == 1)


def test_the_layout_holds_each_dyes_colour_over_the_mean_colour():
    photo = two_dye_photo()
    model = choose_colour_model("auto", photo, 64, 0.0, "hard")
    assert model.kind == "dye_layout" and model.shares == pytest.approx((0.5, 0.5))
    assert model.layout.shape == (64, 64, 3) and np.all(np.isfinite(model.layout))
    # area-weighted, the ratios average to one: the fitted colour stays the cloth's mean colour
    assert np.mean(model.layout, axis=(0, 1)) == pytest.approx(np.ones(3), rel=1e-3)
    red, ecru = model.layout[0, 0], model.layout[0, 8]
    assert red[0] / red[1] > 5 and ecru[0] / ecru[1] < 1.2
    assert model.as_record() == {"kind": "dye_layout", "dye_groups": 2, "shares": [0.5, 0.5], "mixing": "hard"}
    # k-means can leave a group with no pixel: it is not counted as a dye
    assert ColourModel("dye_layout", model.layout, (0.5, 0.0, 0.5)).as_record()["dye_groups"] == 2
    groups = (np.arange(64) // 8 % 2)[None, :].repeat(64, axis=0)
    assert np.allclose(layout_texture(photo, groups, 64, 0.0, "hard")[0], model.layout)


def test_a_mixed_pixel_gets_the_mixture_of_the_dyes_with_its_shading_divided_out():
    red, ecru, navy = np.array([0.55, 0.05, 0.05]), np.array([0.62, 0.58, 0.48]), np.array([0.03, 0.05, 0.3])
    pixels = np.array([[0.4 * red, 0.9 * ecru, 0.7 * (0.25 * red + 0.75 * ecru), 0.5 * (0.5 * ecru + 0.5 * navy)]])
    mixed = mixed_colours(pixels, np.stack([red, ecru, navy]))
    expected = np.array([[red, ecru, 0.25 * red + 0.75 * ecru, 0.5 * ecru + 0.5 * navy]])
    assert mixed == pytest.approx(expected, abs=1e-9)
    # a colour no non-negative mixture reaches takes the nearest one that is
    assert mixed_colours(np.array([[[0.0, 1.0, 0.0]]]), np.stack([red, ecru]))[0, 0] == pytest.approx(ecru, abs=1e-9)


def test_a_group_the_other_dyes_mix_to_is_the_band_where_yarns_meet_not_a_dye():
    indigo, ecru, madder = np.array([0.04, 0.07, 0.15]), np.array([0.44, 0.37, 0.29]), np.array([0.5, 0.08, 0.05])
    edge = 0.6 * indigo + 0.4 * ecru
    assert np.array_equal(dye_colours(np.stack([indigo, ecru, 0.8 * edge])), np.stack([indigo, ecru]))
    assert len(dye_colours(np.stack([indigo, ecru, madder]))) == 3
    assert len(dye_colours(np.stack([indigo, ecru]))) == 2  # two groups are always two dyes


def test_the_mixed_layout_follows_a_blurred_dye_edge_and_keeps_dark_pixels_on_their_group():
    from scipy import ndimage

    photo = ndimage.gaussian_filter(two_dye_photo(), (0, 1.5, 0))  # defocus mixes the stripes' edges
    photo[0, 0] = DARK_LUMINANCE / 10  # a near-black pixel: its chromaticity is noise
    groups = dye_groups(photo)
    hard, shares = layout_texture(photo, groups, 64, 0.0, "hard")
    mixed, mixed_shares = layout_texture(photo, groups, 64, 0.0, "mixed")
    assert mixed_shares == shares and np.all(np.isfinite(mixed))
    assert np.array_equal(mixed[0, 0], hard[0, 0])
    # across a stripe edge the hard layout steps from one dye to the other; the mixed one passes through their mixtures
    row = 32
    hard_steps, mixed_steps = np.abs(np.diff(hard[row, :, 1])), np.abs(np.diff(mixed[row, :, 1]))
    assert mixed_steps.max() < 0.7 * hard_steps.max()
    # inside a stripe, far from its edges, both give the dye's colour
    assert mixed[row, 12] == pytest.approx(hard[row, 12], rel=0.02)
    with pytest.raises(ValueError, match="layout_mixing"):
        layout_texture(photo, groups, 64, 0.0, "soft")


def test_one_dye_or_one_colour_asked_gives_one_colour():
    photo = two_dye_photo()
    assert choose_colour_model("one_colour", photo, 64, 0.06, "hard").kind == "one_colour"
    grey = np.repeat(photo.mean(axis=-1, keepdims=True), 3, axis=-1)
    for kind in ("auto", "dye_layout"):
        model = choose_colour_model(kind, grey, 64, 0.06, "hard")
        assert model.kind == "one_colour" and model.layout is None
    with pytest.raises(ValueError, match="colour_model"):
        choose_colour_model("stripes", photo, 64, 0.06, "hard")


EMBEDDED = Path(__file__).resolve().parents[1] / "data" / "synthetic"


def embedded_photo(fabric: str, image_id: str) -> np.ndarray:
    """An embedded render in linear RGB."""
    return srgb_to_linear(read_png(EMBEDDED / fabric / f"{image_id}.png"))[..., :3]


# one dye each: a satin whose highlights fade from the dye to white, an open weave whose holes show a dark backdrop
@pytest.mark.parametrize("fabric,image_id", [("satin", "satin_red"), ("satin", "satin_green"),
                                             ("cotton_gauze", "cotton_gauze_charcoal")])
def test_auto_keeps_one_colour_where_one_dye_splits_into_groups(fabric, image_id):
    photo = embedded_photo(fabric, image_id)
    assert choose_colour_model("dye_layout", photo, 64, 0.06, "hard").kind == "dye_layout"  # the groups exist
    assert choose_colour_model("auto", photo, 64, 0.06, "hard").kind == "one_colour"


def holes_over_black(size: int = 64, seed: int = 0) -> np.ndarray:
    """Ivory yarns over a black backdrop: a quarter of the pixels are near-black, with a chromaticity that is noise."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[:size, :size]
    photo = np.array([0.75, 0.73, 0.66]) * (0.9 + 0.1 * rng.random((size, size, 1)))
    holes = ((x % 4) < 2) & ((y % 4) < 2)
    photo[holes] = rng.uniform(0.0, 0.003, size=(int(holes.sum()), 3)) * [1.0, 0.2, 0.2]
    return photo


def test_near_black_pixels_are_not_a_dye_but_a_dark_dye_is(monkeypatch):
    holes = holes_over_black()
    assert choose_colour_model("dye_layout", holes, 64, 0.0, "hard").kind == "dye_layout"  # the noise forms a group
    assert choose_colour_model("auto", holes, 64, 0.0, "hard").kind == "one_colour"
    navy = two_dye_photo(first=(0.01, 0.012, 0.05))  # navy stripes on ecru: dark, but far above the noise
    assert choose_colour_model("auto", navy, 64, 0.0, "hard").kind == "dye_layout"
    monkeypatch.setattr("clothscope.fit.colour.DARK_LUMINANCE", 0.0)  # the rule is what keeps the noise out
    assert choose_colour_model("auto", holes, 64, 0.0, "hard").kind == "dye_layout"


def test_two_dyes_are_two_chromaticity_modes_and_a_highlight_is_not():
    chroma = chromaticity(two_dye_photo().reshape(-1, 3))
    red, ecru = chromaticity(np.array([0.55, 0.05, 0.05])), chromaticity(np.array([0.62, 0.58, 0.48]))
    assert valley_ratio(chroma, red, ecru) < 0.1
    satin = embedded_photo("satin", "satin_red").reshape(-1, 3)
    groups = dye_groups(satin.reshape(256, 256, 3)).ravel()
    dye, highlight = (chromaticity(satin[groups == g].mean(axis=0)) for g in range(2))
    assert valley_ratio(chromaticity(satin), dye, highlight) > VALLEY_FRACTION
