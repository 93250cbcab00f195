"""Errors of a fit against ground truth (clothscope.evaluate), on hand-made cases with known answers."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from clothscope.evaluate.accuracy import (
    effects_comparison,
    fold_normal_error,
    in_working_frame,
    period_error,
    seen_scale,
    stage_costs,
    summarise,
    window_seen_scale,
)
from clothscope.fit.model import FitCamera, plane_grid


def truth_camera(fov: float = 25.0) -> dict:
    return {"origin": [0.0, 0.0, 3.0], "target": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0], "fov_deg": fov}


def test_flat_fit_of_flat_cloth_has_no_fold_error():
    camera = FitCamera(25.0)
    truth = {"camera": truth_camera(), "folds": []}
    assert fold_normal_error(truth, plane_grid(camera, 64, 0.06), camera.fov_deg, camera.distance) == pytest.approx(0.0, abs=1e-3)


def test_a_tilted_fit_is_off_by_its_tilt():
    camera = FitCamera(25.0)
    grid = plane_grid(camera, 64, 0.06)
    grid[..., 2] = np.tan(np.deg2rad(5.0)) * grid[..., 0]  # a 5 degree ramp along x
    truth = {"camera": truth_camera(), "folds": []}
    assert fold_normal_error(truth, grid, camera.fov_deg, camera.distance) == pytest.approx(5.0, abs=0.05)


def test_a_fold_seen_by_a_flat_fit_is_an_error():
    camera = FitCamera(25.0)
    truth = {"camera": truth_camera(), "folds": [{"amplitude": 0.1, "width": 0.2, "angle_deg": 30.0, "centre": 0.0}]}
    assert fold_normal_error(truth, plane_grid(camera, 64, 0.06), camera.fov_deg, camera.distance) > 1.0


def test_period_error_takes_the_closer_knit_period_and_marks_missing_ones():
    knit = {"thread_period_px": 10.0, "course_period_px": 8.0}
    assert period_error(8.4, knit) == pytest.approx(0.05)
    assert period_error(None, knit) == 1.0
    assert period_error(9.0, {"thread_period_px": None}) is None
    assert period_error(10.5, knit, scale=1.05) == pytest.approx(0.0)


def test_seen_scale_follows_the_depth_the_cloth_is_seen_at():
    flat = {"camera": truth_camera(), "folds": []}
    assert seen_scale(flat) == pytest.approx(1.0, abs=2e-3)  # a flat sheet at z = 0 is seen at the nominal scale
    wide = {"amplitude": 0.15, "width": 10.0, "angle_deg": 0.0, "centre": 0.0}  # lifts the whole view by 0.15
    assert seen_scale({"camera": truth_camera(), "folds": [wide]}) == pytest.approx(3.0 / 2.85, rel=2e-3)
    lowered = {"camera": truth_camera(), "folds": [wide | {"amplitude": -0.15}]}
    assert seen_scale(lowered) == pytest.approx(3.0 / 3.15, rel=2e-3)


def test_a_centred_window_sees_the_depth_of_the_centre_not_the_frames_mean():
    ridge = {"amplitude": 0.3, "width": 0.05, "angle_deg": 0.0, "centre": 0.0}  # lifts a narrow band through the centre
    truth = {"camera": truth_camera() | {"resolution": 1024}, "folds": [ridge]}
    centre = window_seen_scale(truth, 64)  # 1/16 of the frame: well inside the ridge's crest
    assert centre == pytest.approx(3.0 / 2.7, rel=0.01)
    assert seen_scale(truth) < 1.05 < centre
    assert window_seen_scale(truth, 1024) == window_seen_scale(truth, 4096) == pytest.approx(seen_scale(truth))


def test_the_truth_is_put_in_the_frame_prepare_cropped_and_scaled():
    """A 1024 px photo cropped to its centre 512 px and downscaled to 256: half the view, threads at a quarter."""
    truth = {"camera": truth_camera(40.0), "folds": [], "thread_period_px": 20.0, "course_period_px": None}
    seen = in_working_frame(truth, {"crop_px": 512, "native_px_per_working_px": 2.0}, 1024)
    assert np.tan(np.deg2rad(seen["camera"]["fov_deg"]) / 2) == pytest.approx(0.5 * np.tan(np.deg2rad(20.0)))
    assert seen["thread_period_px"] == pytest.approx(10.0) and seen["course_period_px"] is None
    assert truth["camera"]["fov_deg"] == 40.0 and truth["thread_period_px"] == 20.0  # the record itself is unchanged
    # a fit of the cropped view's flat centre: no fold error in the cropped frame
    camera = FitCamera(seen["camera"]["fov_deg"])
    assert fold_normal_error(seen, plane_grid(camera, 64, 0.06), camera.fov_deg, camera.distance) == pytest.approx(0.0, abs=1e-3)
    assert in_working_frame(truth, {"crop_px": 256, "native_px_per_working_px": 1.0}, 256) is truth
    assert in_working_frame(truth, None, 1024) is truth


def ablation_rows(mode: str, seconds: float, roughness: float) -> pd.DataFrame:
    return pd.DataFrame({"mode": mode, "psnr_db": [36.0, 36.2], "fold_normal_error_deg": [10.0, 10.0],
                         "roughness_error": [roughness] * 2, "base_color_error": [0.03] * 2,
                         "period_error": [0.02, -1.0], "total_s": [seconds] * 2, "max_rss_mb": [180.0] * 2})


def test_effects_comparison_checks_errors_and_time_ratio():
    table = pd.concat([ablation_rows("planned", 10.0, 0.10), ablation_rows("full", 50.0, 0.05)])
    text = effects_comparison(table, "mode", "planned", "full")
    assert "| time <= 1/4 | 10.0 s | 50.0 s | 0.200 | yes |" in text
    assert "| roughness_error within 5% | 0.1000 | 0.0500 | 2.000 | no |" in text
    assert "| period_error within 5% | 0.0200 | 0.0200 | 1.000 | yes |" in text  # pile rows (-1) left out


def test_the_summary_reports_the_period_prepare_read_beside_the_fitted_one():
    """Rows with a prepare period: its hit rate over periodic images (a pile's -1 left out, a missing lattice a miss)."""
    table = pd.DataFrame({"image_id": ["a", "b", "c", "pile"], "fabric_class": ["plain", "plain", "twill", "velvet"],
                          "status": ["fitted"] * 4, "psnr_db": [35.0] * 4, "fold_normal_error_deg": [5.0] * 4,
                          "roughness_error": [0.02] * 4, "base_color_error": [0.02] * 4, "total_s": [20.0] * 4,
                          "max_rss_mb": [200.0] * 4, "flat_fold_normal_error_deg": [9.0] * 4, "tilt_error_deg": [2.0] * 4,
                          "flat_tilt_error_deg": [4.0] * 4, "roughness": [0.5] * 4, "roughness_true": [0.5] * 4,
                          "period_error": [0.01, 0.20, 0.03, -1.0], "period_error_nominal": [0.01, 0.2, 0.03, -1.0],
                          "prepare_period_error": [0.02, 0.01, 1.0, -1.0], "period_seen_scale": [1.0] * 4})
    text = summarise(table)
    assert "| period within 5% | fraction of 3 periodic | 0.667 | >= 0.9 | no |" in text
    assert "| period read by `prepare` (native resolution) within 5% | fraction of 3 periodic | 0.667 | (for reference) | |" in text
    assert "read by `prepare`" not in summarise(table.drop(columns="prepare_period_error"))


def test_a_stage_without_a_benchmark_file_is_not_measured_and_never_meets_a_time_target(tmp_path):
    """A missing ``benchmark:`` file leaves the stage's time empty; the summary says "not measured", not "yes"."""
    timed = tmp_path / "geometry.tsv"
    timed.write_text("s\th:m:s\tmax_rss\n4.5\t0:00:04\t210.0\n")
    costs = stage_costs({"geometry": str(timed), "material": str(tmp_path / "absent.tsv")})
    assert costs["geometry_s"] == 4.5 and costs["geometry_max_rss_mb"] == 210.0
    assert costs["material_s"] is None and costs["total_s"] is None and costs["max_rss_mb"] is None
    assert stage_costs({"geometry": str(timed)})["total_s"] == 4.5
    base = {"image_id": ["a", "b"], "fabric_class": ["plain"] * 2, "status": ["fitted"] * 2, "psnr_db": [35.0] * 2,
            "fold_normal_error_deg": [5.0] * 2, "roughness_error": [0.02] * 2, "base_color_error": [0.02] * 2,
            "flat_fold_normal_error_deg": [9.0] * 2, "tilt_error_deg": [2.0] * 2, "flat_tilt_error_deg": [4.0] * 2,
            "roughness": [0.5] * 2, "roughness_true": [0.5] * 2, "period_error": [0.01, 0.02]}
    untimed = summarise(pd.DataFrame(base | {"total_s": [None, None], "max_rss_mb": [None, None]}))
    assert "| total_s | median | not measured | <= 30 | not measured |" in untimed
    assert "| max_rss_mb | max | not measured | <= 2048 | not measured |" in untimed
    half = summarise(pd.DataFrame(base | {"total_s": [20.0, None], "max_rss_mb": [200.0, None]}))
    assert "| total_s | median | 20.000 (1 of 2 measured) | <= 30 | yes |" in half
