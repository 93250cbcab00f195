"""The thread-structure descriptor: invariances by construction, hard inputs, and the feature-set report."""
from __future__ import annotations

import re

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import settings as hsettings
from hypothesis import strategies as st
from scipy import ndimage

from clothscope.classify.feature_sets import (
    FEATURE_SETS,
    brdf_line,
    compare_feature_sets,
    group_columns,
    inverse_rendering_gain,
    mcnemar_p,
    relief_line,
    report_markdown,
)
from clothscope.core.config import settings as config_settings
from clothscope.features.structure import (
    LBP_COLUMNS,
    LBP_SCALES,
    SPECTRUM_COLUMNS,
    SPECTRUM_RINGS,
    STRUCTURE_COLUMNS,
    WEAVE_COLUMNS,
    StructureSettings,
    autocorrelation,
    find_lattice,
    lbp_baseline,
    spectrum,
    spectrum_rings,
    structure_features,
    texture_columns,
    weave_rings,
    with_period,
)

SETTINGS = StructureSettings(border=0.1, peak_threshold=10.0, fundamental_fraction=0.3, lbp_scale="pixels")


def weave(size: int = 256, period: float = 10.0, angle_deg: float = 0.0, twill: bool = False) -> np.ndarray:
    """A woven relief: two orthogonal thread families (a twill adds a diagonal float)."""
    y, x = np.mgrid[:size, :size].astype(float)
    a = np.radians(angle_deg)
    u, v = x * np.cos(a) + y * np.sin(a), -x * np.sin(a) + y * np.cos(a)
    h = np.cos(2 * np.pi * u / period) + 0.8 * np.cos(2 * np.pi * v / period)
    if twill:
        h += 0.6 * np.cos(2 * np.pi * (u + v) / (1.5 * period))
    return h


def test_features_are_finite_and_complete():
    features, diag = structure_features(weave(), SETTINGS)
    assert set(features) == set(STRUCTURE_COLUMNS)
    assert all(np.isfinite(v) for v in features.values())
    assert diag["lattice"] and diag["period_px"] == pytest.approx(10.0, rel=0.05)


def test_plain_weave_lattice_is_square():
    features, _ = structure_features(weave(), SETTINGS)
    assert features["s_basis_ratio"] == pytest.approx(1.0, abs=0.05)
    assert features["s_basis_angle"] == pytest.approx(1.0, abs=0.05)
    assert features["s_peak_fraction"] > 0.5


def test_contrast_and_offset_leave_features_unchanged():
    base, _ = structure_features(weave(), SETTINGS)
    other, _ = structure_features(3.0 * weave() + 5.0, SETTINGS)
    for name in STRUCTURE_COLUMNS:
        assert other[name] == pytest.approx(base[name], rel=1e-6, abs=1e-6), name


@pytest.mark.parametrize("angle", [15.0, 30.0, 60.0])
def test_rotation_moves_lattice_features_little(angle):
    base, _ = structure_features(weave(twill=True), SETTINGS)
    turned, _ = structure_features(weave(angle_deg=angle, twill=True), SETTINGS)
    for name in ("s_basis_ratio", "s_basis_angle", "s_peak_fraction"):
        assert turned[name] == pytest.approx(base[name], abs=0.08), name


def cloth(period: float, seed: int = 0) -> np.ndarray:
    """A weave with yarn-scale noise, like a fitted relief: peaks a few bins wide over a noise floor."""
    noise = ndimage.gaussian_filter(np.random.default_rng(seed).normal(size=(256, 256)), period / 4)
    return weave(period=period, twill=True) + 0.5 * noise / noise.std()


@pytest.mark.parametrize("zoom", [0.67, 1.5])
def test_zoom_keeps_features_in_units_of_the_fundamental(zoom):
    base, base_diag = structure_features(cloth(9.0), SETTINGS)
    zoomed, diag = structure_features(cloth(9.0 * zoom), SETTINGS)
    assert diag["period_px"] == pytest.approx(base_diag["period_px"] * zoom, rel=0.04)
    profile = [c for c in STRUCTURE_COLUMNS if c.startswith("s_prof")]
    assert np.median(np.abs([zoomed[c] - base[c] for c in profile])) < 0.3
    for name in ("s_basis_ratio", "s_basis_angle"):
        assert zoomed[name] == pytest.approx(base[name], abs=0.08), name


def lbp_distance(a: dict[str, float], b: dict[str, float]) -> float:
    """Largest difference between the LBP histograms of two rows."""
    return max(abs(a[name] - b[name]) for name in LBP_COLUMNS)


@pytest.mark.parametrize("zoom", [0.67, 1.5])
def test_lbp_at_the_canonical_period_survives_a_zoom_that_moves_the_pixel_lbp(zoom):
    canonical = StructureSettings(border=0.1, peak_threshold=10.0, fundamental_fraction=0.3, lbp_scale="canonical")
    at_pixels = [texture_columns(cloth(p), SETTINGS) for p in (9.0, 9.0 * zoom)]
    at_period = [texture_columns(cloth(p), canonical) for p in (9.0, 9.0 * zoom)]
    features, diagnostics = structure_features(cloth(9.0), SETTINGS)
    assert at_pixels[0] == (features | weave_rings(diagnostics["canonical"]) | spectrum_rings(diagnostics["canonical"])
                            | lbp_baseline(cloth(9.0)))
    assert {k: at_period[0][k] for k in STRUCTURE_COLUMNS} == {k: at_pixels[0][k] for k in STRUCTURE_COLUMNS}
    assert lbp_distance(*at_period) < 0.03
    assert lbp_distance(*at_period) < 0.5 * lbp_distance(*at_pixels)


def test_an_unknown_lbp_scale_is_refused():
    with pytest.raises(ValueError, match="lbp_scale"):
        texture_columns(cloth(9.0), StructureSettings(border=0.1, peak_threshold=10.0, fundamental_fraction=0.3,
                                                      lbp_scale="octaves"))


def test_smooth_shading_and_folds_do_not_change_the_lattice():
    y, x = np.mgrid[:256, :256] / 256.0
    shaded = weave() * (0.5 + x) + 20 * np.sin(2 * np.pi * y)
    base, _ = structure_features(weave(), SETTINGS)
    other, diag = structure_features(shaded, SETTINGS)
    assert diag["lattice"] and diag["period_px"] == pytest.approx(10.0, rel=0.05)
    assert other["s_basis_ratio"] == pytest.approx(base["s_basis_ratio"], abs=0.05)


def test_flat_field_has_no_lattice_and_finite_zeros():
    features, diag = structure_features(np.full((128, 128), 0.3), SETTINGS)
    assert not diag["lattice"]
    assert all(np.isfinite(v) for v in features.values())
    assert features["s_peak_fraction"] == 0.0 and features["s_n_peaks"] == 0.0


# a noise peak clears the ring-relative threshold now and then (none in 400 seeds at 256 px; seed 24437333
# makes one at 10.003 times its ring's median against a threshold of 10): the examples are drawn the same way every run
@hsettings(max_examples=15, deadline=None, derandomize=True)
@given(st.integers(min_value=0, max_value=2**31 - 1), st.sampled_from([64, 100, 256]))
def test_white_noise_finds_no_lattice(seed, size):
    noise = np.random.default_rng(seed).normal(size=(size, size))
    features, diag = structure_features(noise, SETTINGS)
    assert not diag["lattice"]
    assert all(np.isfinite(v) for v in features.values())


@pytest.mark.parametrize("sigma, size", [(2.0, 256), (2.0, 512), (4.0, 512)])
def test_smoothed_noise_finds_no_lattice(sigma, size):
    noise = ndimage.gaussian_filter(np.random.default_rng(7).normal(size=(size, size)), sigma, mode="wrap")
    _, diag = structure_features(noise, SETTINGS)
    assert not diag["lattice"]


def test_lattice_survives_fibre_noise():
    noisy = weave() + 0.5 * np.random.default_rng(3).normal(size=(256, 256))
    _, diag = structure_features(noisy, SETTINGS)
    assert diag["lattice"] and diag["period_px"] == pytest.approx(10.0, rel=0.05)


def colour_repeat(size: int = 256, period: float = 5.0, repeat: float = 32.0) -> np.ndarray:
    """Fine threads under a strong, coarser colour repeat (yarn-dyed stripes), which the field's own peaks take for the fundamental."""
    y, x = np.mgrid[:size, :size].astype(float)
    threads = np.cos(2 * np.pi * x / period) + np.cos(2 * np.pi * y / period)
    return 0.5 * threads + 3.0 * np.cos(2 * np.pi * x / repeat)


def test_a_period_measured_elsewhere_replaces_the_fields_own_fundamental():
    _, own = structure_features(colour_repeat(), SETTINGS)
    assert own["period_px"] == pytest.approx(32.0, rel=0.05)  # the stripes, not the threads
    features, given = structure_features(colour_repeat(), SETTINGS, period_px=5.0)
    assert given["period_px"] == pytest.approx(5.0) and given["lattice"] == own["lattice"]
    assert all(np.isfinite(v) for v in features.values())
    rings = texture_columns(colour_repeat(), SETTINGS, 5.0)
    assert rings == texture_columns(colour_repeat(), SETTINGS, period_px=5.0) != texture_columns(colour_repeat(), SETTINGS)


@pytest.mark.parametrize("period", [None, float("nan"), float("inf"), 0.0, -3.0, 1.0, 200.0])
def test_a_period_that_is_missing_or_outside_the_lattice_band_leaves_the_fundamental(period):
    _, own = structure_features(weave(), SETTINGS)
    _, given = structure_features(weave(), SETTINGS, period_px=period)
    assert given["f0"] == own["f0"]
    lattice = find_lattice(spectrum(weave(64)), SETTINGS)
    assert with_period(lattice, 64, period) == lattice


@pytest.mark.parametrize("field, message", [
    (np.zeros((8, 8)), "smaller"),
    (np.zeros((64, 64, 3)), "2-D"),
    (np.where(np.eye(64) > 0, np.nan, 0.0), "non-finite"),
])
def test_bad_fields_raise_value_error(field, message):
    with pytest.raises(ValueError, match=message):
        structure_features(field, SETTINGS)


def test_settings_are_checked():
    with pytest.raises(ValueError, match="border"):
        config_settings("features.structure", border=0.5)
    with pytest.raises(ValueError, match="peak_threshold"):
        config_settings("features.structure", peak_threshold=1.0)


def test_lbp_baseline_histograms_sum_to_one():
    values = lbp_baseline(weave())
    assert list(values) == list(LBP_COLUMNS)
    for neighbours, radius in LBP_SCALES:
        total = sum(values[f"lbp_{neighbours}_{radius}_{k}"] for k in range(neighbours + 2))
        assert total == pytest.approx(1.0)


def test_lbp_baseline_is_rotation_invariant_for_a_quarter_turn():
    field = weave(twill=True) + ndimage.gaussian_filter(np.random.default_rng(0).normal(size=(256, 256)), 1)
    a, b = lbp_baseline(field), lbp_baseline(np.rot90(field))
    assert max(abs(a[k] - b[k]) for k in a) < 0.01


def rings_of(field: np.ndarray) -> dict[str, float]:
    return {name: texture_columns(field, SETTINGS)[name] for name in WEAVE_COLUMNS}


def test_autocorrelation_is_one_at_no_lag_and_follows_a_cosine():
    stripes = np.cos(2 * np.pi * np.arange(64) / 8.0)[None, :].repeat(64, axis=0)
    acf = autocorrelation(stripes)
    assert acf[64, 64] == pytest.approx(1.0)
    assert acf[64, 64 + 4] == pytest.approx(-1.0, abs=0.05) and acf[64, 64 + 8] == pytest.approx(1.0, abs=0.05)
    assert acf[64 + 5, 64] == pytest.approx(1.0, abs=1e-9)  # along the stripes nothing changes
    assert np.all(autocorrelation(np.full((16, 16), 2.0)) == 0.0)


def test_weave_rings_read_stripes_and_noise_apart():
    striped = rings_of(np.cos(2 * np.pi * np.arange(256) / 10.0)[None, :].repeat(256, axis=0))
    noisy = rings_of(np.random.default_rng(5).normal(size=(256, 256)))
    assert all(striped[f"w_max_{k}"] > 0.9 for k in range(1, 8))  # along the stripes every ring finds them again
    assert striped["w_min_1"] < -0.8  # half a period across them, the opposite phase
    assert all(abs(noisy[f"w_max_{k}"]) < 0.35 for k in range(2, 8))


@pytest.mark.parametrize("angle", [30.0, 60.0])
def test_weave_rings_do_not_turn_with_the_cloth(angle):
    base, turned = rings_of(cloth(9.0)), rings_of(np.asarray(ndimage.rotate(cloth(9.0), angle, reshape=False, mode="reflect")))
    assert np.median([abs(turned[name] - base[name]) for name in WEAVE_COLUMNS]) < 0.05


@pytest.mark.parametrize("zoom", [0.67, 1.5])
def test_weave_rings_are_taken_in_thread_periods(zoom):
    base, zoomed = rings_of(cloth(9.0)), rings_of(cloth(9.0 * zoom))
    assert np.median([abs(zoomed[name] - base[name]) for name in WEAVE_COLUMNS]) < 0.05


def test_weave_rings_of_a_flat_field_are_finite_zeros():
    values = rings_of(np.full((128, 128), 0.3))
    assert list(values) == list(WEAVE_COLUMNS) and all(v == 0.0 for v in values.values())


def canonical_grid(kind: str, size: int = 96) -> np.ndarray:
    """A canonical field (thread period 8 px): stripes one way, or threads both ways (a square lattice)."""
    y, x = np.mgrid[0:size, 0:size] * 2 * np.pi / 8.0
    return np.cos(x) if kind == "stripes" else np.cos(x) + np.cos(y)


def test_spectrum_rings_are_finite_and_a_quarter_turn_or_a_contrast_leaves_them():
    field = cloth(8.0)[:96, :96]
    values = spectrum_rings(field)
    assert list(values) == list(SPECTRUM_COLUMNS) and np.isfinite(list(values.values())).all()
    for other in (spectrum_rings(np.rot90(field)), spectrum_rings(3.0 * field + 2.0)):
        assert max(abs(values[k] - other[k]) for k in values) < 1e-9


def test_spectrum_rings_read_the_threads_directions_at_the_thread_frequency():
    """At one thread frequency, stripes put their power in one direction (a second angular harmonic); a square
    lattice in two at right angles (a fourth harmonic and no second)."""
    ring = 1 + int(np.argmin(np.abs(np.asarray(SPECTRUM_RINGS) - 1.0)))
    stripes, square = spectrum_rings(canonical_grid("stripes")), spectrum_rings(canonical_grid("square"))
    assert stripes[f"p_h2_{ring}"] > 0.5 and square[f"p_h2_{ring}"] < 0.05 < 0.5 < square[f"p_h4_{ring}"]
    assert stripes[f"p_share_{ring}"] > stripes["p_share_1"] + 2  # the power sits on the thread ring


def test_spectrum_rings_of_a_flat_field_are_finite():
    values = spectrum_rings(np.full((64, 64), 0.3))
    assert all(values[f"p_share_{k}"] == pytest.approx(-9.0) for k in range(1, len(SPECTRUM_RINGS) + 1))
    assert all(v == 0.0 for name, v in values.items() if name.startswith("p_h"))


# --------------------------------------------------------------------------- the feature-set report


def _table(source: str, rng: np.random.Generator, informative: bool, missing: tuple[str, ...] = ()) -> pd.DataFrame:
    rows = []
    for c, fabric in enumerate(("a", "b", "c")):
        for k in range(6):
            image_id = f"{fabric}{k}"
            row = {"image_id": image_id, "fabric_class": fabric, "status": "missing" if image_id in missing else "ok", "reason": "",
                   "roughness": 0.0, "specular_norm": 0.0, "r_1": rng.normal(), "z_1": rng.normal(), "n_peaks": 1}
            for name in (*STRUCTURE_COLUMNS, *LBP_COLUMNS):
                row[name] = rng.normal() + (6.0 * c if informative and name.startswith("s_prof") else 0.0)
            if source != "photo":
                row["roughness"], row["specular_norm"] = rng.normal(), rng.normal()
            rows.append(row)
    return pd.DataFrame(rows)


def test_feature_sets_compare_on_the_same_images_and_say_what_the_fit_bought():
    rng = np.random.default_rng(0)
    tables = {"fitted": _table("fitted", rng, True, missing=("a0",)), "photo": _table("photo", rng, False),
              "truth": _table("truth", rng, True)}
    report = compare_feature_sets(tables, "auto", "discriminant")
    assert set(report["feature_set"]) == {s.name for s in FEATURE_SETS}
    scored = report[report["status"] == "ok"]
    assert (scored["n"] == 17).all()  # a0 is unusable in the fitted table, so no set sees it
    assert scored.set_index("feature_set").loc["structure_brdf_fitted", "accuracy"] > 0.9
    assert bool(scored.set_index("feature_set").loc["lbp_photo", "photo_only"])
    line = inverse_rendering_gain(report, "structure_brdf_fitted")
    assert line.startswith("Inverse rendering bought") and "same 17 images" in line
    best = report[report["photo_only"] & (report["status"] == "ok")]["accuracy"].max()
    assert line.endswith(f"The photo alone leaves {100 * (1 - best):.1f} points to a perfect score on these images: "
                         "the most the fit could add here.")
    assert np.isfinite(report[["accuracy", "wilson_low", "wilson_high"]].to_numpy(float)).all()
    # each set is paired image by image with the best photo-only set: the split of the images only one of
    # them got right accounts for the whole difference in correct images
    rows = report.set_index("feature_set")
    reference = rows.loc["structure_brdf_fitted", "photo_reference"]
    assert reference in rows.index and bool(rows.loc[reference, "photo_only"])
    for name in ("structure_brdf_fitted", "paper_fitted", "auto_truth"):
        row = rows.loc[name]
        assert int(row["only_this_right"]) - int(row["only_photo_right"]) == int(row["correct"]) - int(rows.loc[reference, "correct"])
        assert 0.0 < float(row["mcnemar_p"]) <= 1.0
    assert pd.isna(rows.loc["lbp_photo", "mcnemar_p"])
    assert f"only structure_brdf_fitted was right on {int(rows.loc['structure_brdf_fitted', 'only_this_right'])}" in line
    assert "against the best photo" in report_markdown(report, line, list(tables), "discriminant")


def test_brdf_line_counts_what_the_fitted_brdf_adds_to_the_photo_structure_on_the_same_images():
    report = pd.DataFrame([{"feature_set": "structure_photo", "status": "ok", "correct": 38, "n": 42},
                           {"feature_set": "photo_plus_brdf", "status": "ok", "correct": 41, "n": 42}])
    line = brdf_line(report)
    assert line == ("The fitted BRDF beside the photo's structure descriptor: photo_plus_brdf 41/42 against "
                    "structure_photo 38 (+3 images).")
    assert line in report_markdown(report.assign(description="", n_features=1, accuracy=0.9, wilson_low=0.8,
                                                 wilson_high=0.95, chance=0.1, reason=""), "gain", ["fitted", "photo"], "none")
    assert brdf_line(report.iloc[:1]) == ""  # a classifier without fitted maps has no such set
    assert brdf_line(report.assign(status=["ok", "not scored"])) == ""


def _report(**accuracy: float) -> pd.DataFrame:
    return pd.DataFrame([{"feature_set": name, "status": "ok", "accuracy": value, "photo_only": name.endswith("_photo")}
                         for name, value in accuracy.items()])


def test_relief_line_sets_the_fitted_set_against_the_true_relief_only_where_it_was_scored():
    neither = relief_line(_report(structure_truth=1.0, auto_fitted=0.4, lbp_photo=0.5, structure_photo=0.45), "auto_fitted")
    assert "scores 100.0%, auto_fitted 40.0% and the photo's lbp_photo 50.0%" in neither
    assert "the class is in the relief, but neither" in neither
    assert "so the fit loses it" in relief_line(_report(structure_truth=1.0, auto_fitted=0.4, lbp_photo=0.95), "auto_fitted")
    assert "keeps about as much" in relief_line(_report(structure_truth=1.0, auto_fitted=0.95, lbp_photo=0.5), "auto_fitted")
    assert relief_line(_report(auto_fitted=0.4, lbp_photo=0.5), "auto_fitted") == ""  # a real photo set: no truth
    assert relief_line(_report(structure_truth=1.0, auto_fitted=0.4), "auto_fitted") == ""  # no photo-only set
    empty = pd.DataFrame(columns=["feature_set", "status"])
    assert neither in report_markdown(empty, "gain", ["fitted"], "none", neither)
    assert "\n\nThread scale: 3 finer.\n\n" in report_markdown(empty, "gain", ["fitted"], "none", neither, "Thread scale: 3 finer.")
    assert "Against the true relief" not in report_markdown(empty, "gain", ["fitted"], "none")


def test_mcnemar_p_is_the_exact_two_sided_binomial_test_of_the_discordant_images():
    assert mcnemar_p(9, 2) == pytest.approx(2 * (1 + 11 + 55) / 2**11)  # 2 P(X <= 2), X ~ B(11, 1/2)
    assert mcnemar_p(2, 9) == pytest.approx(mcnemar_p(9, 2))
    assert mcnemar_p(0, 0) == 1.0 and mcnemar_p(3, 3) == 1.0
    assert mcnemar_p(0, 10) == pytest.approx(2 / 2**10)
    with pytest.raises(ValueError, match=">= 0"):
        mcnemar_p(-1, 2)


def test_truth_sets_are_not_scored_when_some_images_lack_ground_truth():
    rng = np.random.default_rng(1)
    tables = {"fitted": _table("fitted", rng, True), "photo": _table("photo", rng, False),
              "truth": _table("truth", rng, True, missing=("b2",))}
    report = compare_feature_sets(tables, "auto", "none").set_index("feature_set")
    assert report.loc["paper_truth", "status"] == "not scored"
    assert "ground truth" in report.loc["paper_truth", "reason"]


def test_group_columns():
    columns = ["roughness", "specular_norm", "r_1", "z_1", "n_peaks", "x_angle_deg", *STRUCTURE_COLUMNS, *LBP_COLUMNS]
    assert group_columns("paper", columns) == ["roughness", "specular_norm", "r_1", "z_1", "n_peaks", "x_angle_deg"]
    assert group_columns("structure_brdf", columns) == ["roughness", "specular_norm", *STRUCTURE_COLUMNS]
    assert group_columns("lbp", columns) == list(LBP_COLUMNS)
    assert group_columns("structure", [*columns, *WEAVE_COLUMNS]) == [*STRUCTURE_COLUMNS, *WEAVE_COLUMNS]


def test_only_the_ring_sources_sets_take_the_weave_rings():
    from clothscope.classify.feature_sets import RING_SOURCES, source_columns

    own = [*STRUCTURE_COLUMNS, *WEAVE_COLUMNS, *LBP_COLUMNS]
    columns = [f"{source}.{c}" for source in ("fitted", "photo", "truth") for c in own]
    assert "truth" not in RING_SOURCES  # the true relief scores 100% without them
    for source in ("fitted", "photo", "truth"):
        rings = [c for c in source_columns(columns, source, "texture") if c.split(".", 1)[1] in WEAVE_COLUMNS]
        assert len(rings) == (len(WEAVE_COLUMNS) if source in RING_SOURCES else 0), source
    with pytest.raises(ValueError, match="unknown"):
        group_columns("colour", columns)


def test_nested_selection_picks_the_informative_set_inside_every_fold():
    from clothscope.classify.loocv import loocv

    rng = np.random.default_rng(2)
    table = _table("fitted", rng, True)
    candidates = {"noise": ["lbp_8_1_0", "lbp_8_1_1"], "profile": [f"s_prof_{k}" for k in range(1, 4)]}
    result = loocv(table, [], select_from=candidates)
    assert sum(result.selected.values()) == result.n == 18
    assert result.selected.get("profile", 0) >= 16 and result.accuracy > 0.9


def test_a_feature_set_says_which_source_it_pools_and_whether_it_votes():
    sets = {s.name: s for s in FEATURE_SETS}
    assert sets["vote_fitted"].pooled() == ("fitted", True)
    assert sets["auto_photo"].pooled() == ("photo", False)
    assert sets["lbp_photo"].pooled() is None


def test_the_vote_averages_every_candidates_posteriors_in_every_fold():
    from clothscope.classify.loocv import class_posteriors, loocv
    from clothscope.classify.model import train_model

    rng = np.random.default_rng(2)
    table = _table("fitted", rng, True)
    candidates = {"noise": ["lbp_8_1_0", "lbp_8_1_1"], "profile": [f"s_prof_{k}" for k in range(1, 4)],
                  "again": ["lbp_8_1_0", "lbp_8_1_1"]}  # the same columns as "noise": it does not vote twice
    result = loocv(table, [], select_from=candidates, vote=True)
    assert result.selected == {"noise": 18, "profile": 18} and result.accuracy > 0.9
    rows, query = table.iloc[1:], table.iloc[[0]]
    by_hand = np.mean([class_posteriors(train_model(rows, candidates[name]), query, ["a", "b", "c"], None)[0]
                       for name in ("noise", "profile")], axis=0)
    assert np.allclose(result.predictions.iloc[0][["p_a", "p_b", "p_c"]].to_numpy(float), by_hand)
    assert np.isfinite(result.predictions[["p_a", "p_b", "p_c"]].to_numpy(float)).all()


def test_the_record_can_vote_and_its_model_for_new_photos_holds_every_set_that_voted(tmp_path):
    """``classify.feature_set: vote``: LOOCV averages the candidates' QDAs, and the saved model does the same."""
    from clothscope.classify.feature_sets import joined_table
    from clothscope.classify.job import classify_job
    from clothscope.classify.model import load_model, predict

    rng = np.random.default_rng(4)
    paths = {}
    for source in ("fitted", "photo"):
        table = _table(source, rng, True).assign(normal_source=source, mitsuba_variant="llvm_ad_rgb", config_hash="h")
        table.loc[table["image_id"] == "c5", "fabric_class"] = ""  # a query
        paths[source] = tmp_path / f"{source}.parquet"
        table.to_parquet(paths[source])
    out = classify_job(paths["fitted"], "config/physics.yaml", "fitted", "auto", tmp_path / "reports", tmp_path / "model",
                       feature_set="vote", photo_table_path=paths["photo"], subspace="discriminant")
    assert out["n"] == 17 and out["accuracy"] > 0.9
    model = load_model(tmp_path / "model")
    assert len(model.members) > 3 and {"structure_brdf", "photo_profile"} <= set(model.members)
    assert model.metadata["metadata"]["feature_set"] == "vote" and model.metadata["metadata"]["choice"] is None
    assert model.metadata["metadata"]["prune"] == 0.0
    summary = (tmp_path / "reports" / "summary.md").read_text()
    assert "Sets that voted, folds: " in summary and f"averages the posteriors of {len(model.members)} QDAs: `structure_brdf`" in summary
    without = re.search(r"Without the fit \(the same classifier on the photo alone, .*\): (\d+)/17 against (\d+)/17 with it", summary)
    assert without and int(without.group(2)) == out["correct"] and int(without.group(1)) > 12
    joined = joined_table({s: pd.read_parquet(p) for s, p in paths.items()})
    query = predict(model, joined[joined["image_id"] == "c5"])
    by_member = [predict(member, joined[joined["image_id"] == "c5"])[["p_a", "p_b", "p_c"]].to_numpy(float)
                 for member in model.members.values()]
    assert np.allclose(query[["p_a", "p_b", "p_c"]].to_numpy(float), np.mean(by_member, axis=0))
    assert query["predicted_class"].item() == "c"


def test_the_without_fit_line_pairs_the_two_classifiers_on_the_images_both_scored():
    from types import SimpleNamespace

    from clothscope.classify.job import without_fit_line
    from clothscope.classify.loocv import LoocvResult

    def scored(ids: str, predicted: str) -> pd.Series:
        return LoocvResult.right_by_image(SimpleNamespace(predictions=pd.DataFrame(
            {"image_id": list(ids), "true_class": ["a"] * len(ids), "predicted_class": list(predicted)})))

    line = without_fit_line(scored("pqrs", "aaba"), scored("pqrst", "abbba"))  # t: scored only without the fit
    assert line.endswith("1/4 against 3/4 with it; image by image, only with the fit right on 2 and only without it on 0 "
                         "(exact McNemar p = 0.5).")


def test_the_photo_only_loocv_is_what_the_classify_rule_scores_for_the_photo_source(tmp_path):
    """``photo_only_loocv`` (the fitted summary's "without the fit" line) scores what ``features.normal_source: photo``
    scores: the same LOOCV predictions, image by image."""
    from clothscope.classify.job import classify_job, photo_only_loocv

    table = _table("photo", np.random.default_rng(6), False).assign(normal_source="photo", mitsuba_variant="llvm_ad_rgb",
                                                                   config_hash="h")
    table.to_parquet(tmp_path / "photo.parquet")
    classify_job(tmp_path / "photo.parquet", "config/physics.yaml", "photo", "auto", tmp_path / "reports", tmp_path / "model",
                 feature_set="vote", subspace="discriminant", prune=0.05)
    rule = pd.read_csv(tmp_path / "reports" / "predictions.csv", dtype={"image_id": str})
    rule = rule[rule["split"] == "loocv"].set_index("image_id")["predicted_class"].sort_index()
    alone = photo_only_loocv(table, None, "vote", "auto", "discriminant", vote=True, prune=0.05)
    assert alone.predictions.set_index("image_id")["predicted_class"].sort_index().equals(rule) and len(rule) == 18


def test_a_pruned_record_leaves_out_fitted_sets_that_carry_no_class(tmp_path):
    """``classify.prune``: fits that carry no class lose the inner sign test, so neither the folds nor the model let
    the fitted maps' own sets vote, while the photo's sets do."""
    from clothscope.classify.job import classify_job
    from clothscope.classify.model import load_model

    rng = np.random.default_rng(5)
    paths = {}
    for source, informative in (("fitted", False), ("photo", True)):
        table = _table(source, rng, informative).assign(normal_source=source, mitsuba_variant="llvm_ad_rgb", config_hash="h")
        paths[source] = tmp_path / f"{source}.parquet"
        table.to_parquet(paths[source])
    out = classify_job(paths["fitted"], "config/physics.yaml", "fitted", "auto", tmp_path / "reports", tmp_path / "model",
                       feature_set="vote", photo_table_path=paths["photo"], subspace="discriminant", prune=0.05)
    model = load_model(tmp_path / "model")
    fitted_only = {"structure_brdf", "profile_brdf", "paper", "lbp", "texture_brdf"}
    assert not fitted_only & set(model.members) and "photo_profile" in model.members
    assert model.metadata["metadata"]["prune"] == 0.05 and out["accuracy"] > 0.9
    summary = (tmp_path / "reports" / "summary.md").read_text()
    assert "photo_profile 18" in summary and not re.search(r"[ :]structure_brdf \d+", summary)  # no fold let it vote


def test_joined_table_marks_an_image_unusable_when_any_source_fails():
    from clothscope.classify.feature_sets import classifier_candidates, joined_table

    rng = np.random.default_rng(3)
    joined = joined_table({"fitted": _table("fitted", rng, True), "photo": _table("photo", rng, False, missing=("c5",))})
    row = joined.set_index("image_id").loc["c5"]
    assert row["status"] == "missing" and row["reason"].startswith("photo:")
    assert "fitted.s_prof_1" in joined and "photo.s_prof_1" in joined
    sets = classifier_candidates("auto", "fitted", [*joined.columns, f"photo.{SPECTRUM_COLUMNS[0]}"])
    assert set(sets) == {"structure_brdf", "profile_brdf", "paper", "lbp", "texture_brdf", "texture_shade_brdf", "photo_structure", "plus_photo",
                         "photo_profile", "photo_paper", "photo_lbp", "photo_texture", "photo_spectrum",
                         "photo_structure_brdf"}
    assert sets["plus_photo"] == sets["structure_brdf"] + sets["photo_structure"]
    assert sets["photo_structure_brdf"] == sets["photo_structure"] + ["fitted.roughness", "fitted.specular_norm"]
    assert all(c.startswith("photo.") for name in ("photo_profile", "photo_paper", "photo_lbp", "photo_texture") for c in sets[name])
    assert sets["photo_texture"] == sets["photo_structure"] + sets["photo_lbp"]
    assert sets["photo_spectrum"] == [*sets["photo_structure"], f"photo.{SPECTRUM_COLUMNS[0]}"]  # with the spectrum rings
    assert sets["photo_profile"] == [f"photo.s_prof_{k}" for k in range(1, 11) if f"photo.s_prof_{k}" in joined]
    assert "photo_lbp" not in classifier_candidates("auto", "photo", joined.columns)  # a photo classifier has them as its own
    with pytest.raises(ValueError, match="needs sources"):
        classifier_candidates("photo_structure", "photo", joined.columns)
    from clothscope.core.config import config_schema

    forcible = config_schema()["properties"]["classify"]["properties"]["feature_set"]["enum"]
    assert set(forcible) == {"auto", "vote", *sets}  # every candidate can be forced, and nothing else
    assert classifier_candidates("photo_lbp", "fitted", joined.columns) == {"photo_lbp": sets["photo_lbp"]}


def test_joined_table_keeps_the_spectrum_rings_for_the_spectrum_sets():
    from clothscope.classify.feature_sets import joined_table, source_columns

    rng = np.random.default_rng(4)
    photo = _table("photo", rng, False)
    photo = pd.concat([photo, pd.DataFrame(rng.normal(size=(len(photo), len(SPECTRUM_COLUMNS))), columns=list(SPECTRUM_COLUMNS))],
                      axis=1)
    joined = joined_table({"photo": photo})
    spectrum = source_columns(joined.columns, "photo", "spectrum")
    assert spectrum[-len(SPECTRUM_COLUMNS):] == [f"photo.{c}" for c in SPECTRUM_COLUMNS]
    assert np.allclose(joined[f"photo.{SPECTRUM_COLUMNS[0]}"], photo[SPECTRUM_COLUMNS[0]])


def test_diagnosis_of_a_fit_that_equals_the_truth_finds_nothing_wrong(tmp_path):
    import json

    from conftest import SYNTHETIC

    from clothscope.core.imageio import write_exr
    from clothscope.features.diagnosis import diagnosis_job
    from clothscope.features.sources import load_truth

    images = {}
    for image_id in ("canvas_red", "canvas_navy"):
        path = SYNTHETIC / "canvas" / f"{image_id}.png"
        truth = load_truth(path)
        folder = tmp_path / image_id
        folder.mkdir()
        write_exr(folder / "normal.exr", truth.normals.astype(np.float32))
        write_exr(folder / "height.exr", np.repeat(truth.field[..., None], 3, axis=2).astype(np.float32))
        (folder / "state.json").write_text(json.dumps({"status": "fitted", "texels_per_pixel": 1.0, "unexplained_share": 0.0, "material": {
            "roughness": truth.roughness, "specular": truth.specular, "base_color": [0.5, 0.5, 0.5]}}))
        images[image_id] = {"fabric_class": "canvas", "path": str(path), "fit_dir": str(folder)}
    table = diagnosis_job(images, SETTINGS, tmp_path / "d.md", tmp_path / "d.csv", tmp_path / "d.png")
    assert len(table) == 2 and np.allclose(table["fitted_period_ratio"], 1.0)
    assert "| canvas | 2 / 2 (2) of 2 | 2 (2) | 1.000 | 0.00 (" in (tmp_path / "d.md").read_text()
    assert "agrees with the truth" in (tmp_path / "d.md").read_text() and (tmp_path / "d.png").stat().st_size > 0
