"""Tiles: sub-windows of a map described on their own, extra training rows that never leak into a score."""
from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from conftest import SCHEMAS, SYNTHETIC

import clothscope.classify.loocv as loocv_module
from clothscope.classify.feature_sets import joined_table, joined_tiles
from clothscope.classify.loocv import loocv
from clothscope.classify.model import predict, train_model
from clothscope.classify.rows import with_tiles
from clothscope.core.schema import load_schema, validate
from clothscope.features.structure import MIN_FIELD, TILE_FEATURES, StructureSettings, window
from clothscope.features.table import feature_table_job, features_job, tile_rows, tile_schema
from clothscope.features.tiles import TileSettings, tile_columns, tile_fields, view_fields, view_periods

FEATURES = validate({}, load_schema(SCHEMAS / "config.schema.yaml"), "config")["features"]
STRUCTURE = StructureSettings(border=0.1, peak_threshold=10.0, fundamental_fraction=0.3, lbp_scale="pixels")


def weave(size: int = 200, period: float = 9.0) -> np.ndarray:
    y, x = np.mgrid[:size, :size].astype(float)
    return np.cos(2 * np.pi * x / period) + 0.8 * np.cos(2 * np.pi * y / period)


def test_tiles_cover_the_analysis_window_corner_to_corner():
    field = np.arange(200 * 200, dtype=float).reshape(200, 200)
    tiles = tile_fields(field, 0.1, TileSettings(grid=3, size=0.5))
    whole = window(field, 0.1)
    assert whole.shape == (160, 160) and len(tiles) == 9
    assert all(t.shape == (80, 80) for t in tiles)
    np.testing.assert_array_equal(tiles[0], whole[:80, :80])
    np.testing.assert_array_equal(tiles[4], whole[40:120, 40:120])
    np.testing.assert_array_equal(tiles[8], whole[80:, 80:])


def test_no_tiles_when_switched_off_or_too_small_and_bad_settings_are_refused():
    assert tile_fields(weave(), 0.1, TileSettings(grid=0, size=0.55)) == []
    assert tile_fields(weave(60), 0.1, TileSettings(grid=3, size=0.5)) == []  # 24 px tiles < MIN_FIELD
    assert MIN_FIELD > 24
    for grid, size in ((-1, 0.5), (3, 0.0), (3, 1.5)):
        with pytest.raises(ValueError, match="grid"):
            tile_fields(weave(), 0.1, TileSettings(grid=grid, size=size))


def test_tile_rows_are_finite_and_of_the_tile_schema():
    rows = tile_rows("img", weave(), STRUCTURE, TileSettings(grid=2, size=0.6))
    assert [r["tile"] for r in rows] == [0, 1, 2, 3]
    assert set(rows[0]) == set(tile_schema().names) == {"image_id", "tile", *TILE_FEATURES}
    assert all(np.isfinite(r[name]) for r in rows for name in TILE_FEATURES)
    # a periodic field looks alike in every tile: the period-relative profile agrees
    assert max(abs(r["s_prof_3"] - rows[0]["s_prof_3"]) for r in rows) < 0.2


def strongest_period(field: np.ndarray) -> tuple[float, float]:
    """Period (px) and direction (degrees, 0 along x) of the strongest Fourier component of a square field."""
    power = np.abs(np.fft.fft2(field - field.mean())) ** 2
    n = field.shape[0]
    fy, fx = np.unravel_index(np.argmax(power), power.shape)
    fy, fx = (fy + n // 2) % n - n // 2, (fx + n // 2) % n - n // 2
    return n / np.hypot(fx, fy), np.degrees(np.arctan2(fy, fx)) % 180.0


def test_views_turn_and_zoom_the_threads():
    y, x = np.mgrid[:250, :250].astype(float)
    stripes = np.cos(2 * np.pi * x / 10.0)
    turned, closer, farther = view_fields(stripes, 0.1, TileSettings(grid=0, size=0.5, turns=(90.0,), zooms=(1.5, 0.6)))
    assert turned.shape == (200, 200) and closer.shape == (200, 200) and farther.shape == (120, 120)
    period, direction = strongest_period(turned)
    assert period == pytest.approx(10.0, rel=0.03) and direction == pytest.approx(90.0, abs=2.0)
    assert strongest_period(closer)[0] == pytest.approx(15.0, rel=0.05)  # threads look 1.5 times larger
    assert strongest_period(farther)[0] == pytest.approx(6.0, rel=0.05)
    diagonal = view_fields(stripes, 0.1, TileSettings(grid=0, size=0.5, turns=(45.0,)))[0]
    assert diagonal.shape[0] == int(200 / np.sqrt(2))  # the upright square inside the turned one


def test_views_are_numbered_after_the_tiles_and_refused_when_bad_or_too_small():
    rows = tile_rows("img", weave(), STRUCTURE, TileSettings(grid=2, size=0.6, turns=(30.0,), zooms=(1.3, 0.77)))
    assert [r["tile"] for r in rows] == [0, 1, 2, 3, 4, 5, 6]
    assert [r["tile"] for r in tile_rows("img", weave(), STRUCTURE, TileSettings(grid=0, size=0.6, zooms=(1.3,)))] == [0]
    assert view_fields(weave(48), 0.1, TileSettings(grid=0, size=0.5, turns=(30.0,), zooms=(0.77,))) == []
    for turns, zooms in (((float("nan"),), ()), ((), (0.0,)), ((), (float("inf"),))):
        with pytest.raises(ValueError, match="views"):
            view_fields(weave(), 0.1, TileSettings(grid=0, size=0.5, turns=turns, zooms=zooms))


def test_tiles_and_views_take_the_period_given_a_zoom_scaling_it():
    tiles = TileSettings(grid=2, size=0.6, turns=(30.0,), zooms=(1.3, 0.77))
    assert view_periods(None, tiles) == [None, None, None]
    assert view_periods(9.0, tiles) == pytest.approx([9.0, 9.0 * 1.3, 9.0 * 0.77])
    given, own = tile_columns(weave(), STRUCTURE, tiles, 18.0), tile_columns(weave(), STRUCTURE, tiles)
    assert sorted(given) == sorted(own) == [0, 1, 2, 3, 4, 5, 6]
    assert all(given[k]["s_prof_1"] != own[k]["s_prof_1"] for k in given)  # every row reads the given period
    assert tile_columns(weave(), STRUCTURE, tiles, 9.0)[0]["s_prof_1"] == pytest.approx(own[0]["s_prof_1"], abs=0.05)


def test_features_job_writes_tiles_only_for_a_usable_image(tmp_path):
    image = tmp_path / "q.png"
    shutil.copy(SYNTHETIC / "canvas" / "canvas_red.png", image)
    out = tmp_path / "missing"
    features_job("q", "", "truth", str(image), None, FEATURES, str(out / "q.parquet"), str(out / "q.png"),
                 tiles_path=str(out / "tiles" / "q.parquet"))
    assert pq.read_table(out / "tiles" / "q.parquet").num_rows == 0  # no ground truth beside it: no tiles
    truth = SYNTHETIC / "canvas" / "canvas_red.png"
    features_job("canvas_red", "canvas", "truth", str(truth), None, FEATURES, str(tmp_path / "c.parquet"),
                 str(tmp_path / "c.png"), tiles_path=str(tmp_path / "tiles" / "c.parquet"))
    tiles = pq.read_table(tmp_path / "tiles" / "c.parquet")
    views = len(FEATURES["tiles"]["turns"]) + len(FEATURES["tiles"]["zooms"])
    assert tiles.num_rows == FEATURES["tiles"]["grid"] ** 2 + views and tiles.schema.equals(tile_schema(), check_metadata=False)
    target = tmp_path / "table.parquet"
    feature_table_job([tmp_path / "c.parquet", out / "q.parquet"], target,
                      [tmp_path / "tiles" / "c.parquet", out / "tiles" / "q.parquet"], tmp_path / "tiles" / "table.parquet")
    assert pq.read_table(tmp_path / "tiles" / "table.parquet").num_rows == tiles.num_rows


def blobs(n_per_class: int = 4, seed: int = 0) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Two classes apart along ``s_prof_1``; each image has four tiles scattered around its own row."""
    rng = np.random.default_rng(seed)
    rows, tiles = [], []
    for k, name in enumerate(("plain", "twill")):
        for i in range(n_per_class):
            image = f"{name}_{i}"
            centre = np.array([4.0 * k, 0.0]) + rng.normal(scale=0.5, size=2)
            rows.append({"image_id": image, "fabric_class": name, "status": "ok", "reason": "", "roughness": 0.5 + k,
                         "specular_norm": 0.3, **{c: 0.0 for c in TILE_FEATURES}, "s_prof_1": centre[0], "s_prof_2": centre[1]})
            for t in range(4):
                jitter = centre + rng.normal(scale=0.5, size=2)
                tiles.append({"image_id": image, "tile": t, **{c: 0.0 for c in TILE_FEATURES},
                              "s_prof_1": jitter[0], "s_prof_2": jitter[1]})
    return pd.DataFrame(rows), pd.DataFrame(tiles)


def test_with_tiles_adds_only_the_tiles_of_the_given_images_with_their_labels():
    table, tiles = blobs()
    X = table[["s_prof_1"]].to_numpy()[:2]
    y = np.array(["plain", "plain"], dtype=object)
    X2, y2 = with_tiles(X, y, ["plain_0", "plain_1"], tiles, ["s_prof_1"])
    assert X2.shape == (2 + 8, 1) and list(y2) == ["plain"] * 10
    assert with_tiles(X, y, ["plain_0"], None, ["s_prof_1"])[0] is X
    assert with_tiles(X, y, ["plain_0", "plain_1"], tiles, ["roughness"])[0] is X  # a column no tile describes
    joined = tiles.rename(columns={"s_prof_1": "fitted.s_prof_1"})
    assert with_tiles(X, y, ["plain_0", "plain_1"], joined, ["fitted.s_prof_1"])[0].shape == (10, 1)


def test_joined_tiles_replace_texture_columns_and_keep_each_images_other_columns():
    table, tiles = blobs()
    joined = joined_tiles({"fitted": table, "photo": table}, {"fitted": tiles, "photo": tiles})
    assert len(joined) == len(tiles) and set(joined_table({"fitted": table}).columns) <= set(joined.columns)
    first = joined[(joined["image_id"] == "twill_1") & (joined["tile"] == 2)].iloc[0]
    source = tiles[(tiles["image_id"] == "twill_1") & (tiles["tile"] == 2)].iloc[0]
    assert first["fitted.s_prof_1"] == source["s_prof_1"] and first["photo.s_prof_2"] == source["s_prof_2"]
    assert first["fitted.roughness"] == 1.5 and first["fabric_class"] == "twill"  # the image's own values
    assert joined_tiles({"fitted": table}, {"fitted": tiles.iloc[:0]}) is None
    assert joined_tiles({"fitted": table, "photo": table}, {"fitted": tiles}) is None


def test_loocv_never_trains_a_fold_on_the_tiles_of_the_image_it_scores(monkeypatch):
    table, tiles = blobs()
    frame = joined_table({"fitted": table})
    tile_frame = joined_tiles({"fitted": table}, {"fitted": tiles})
    seen: list[set[str]] = []
    real = loocv_module.with_tiles

    def spy(X, y, ids, tile_rows, columns):
        seen.append({str(i) for i in ids})
        return real(X, y, ids, tile_rows, columns)

    monkeypatch.setattr(loocv_module, "with_tiles", spy)
    columns = ["fitted.s_prof_1", "fitted.s_prof_2"]
    result = loocv(frame, columns, "auto", subspace="none", tiles=tile_frame)
    assert len(seen) == len(frame) and result.correct == len(frame)
    for image, trained_on in zip(frame["image_id"], seen):
        assert image not in trained_on and len(trained_on) == len(frame) - 1


def test_tiles_change_what_a_model_learns():
    table, tiles = blobs()
    frame = joined_table({"fitted": table})
    tile_frame = joined_tiles({"fitted": table}, {"fitted": tiles})
    columns = ["fitted.s_prof_1", "fitted.s_prof_2"]
    plain = train_model(frame, columns, "auto")
    tiled = train_model(frame, columns, "auto", tiles=tile_frame)
    assert plain.class_counts == tiled.class_counts == {"plain": 4, "twill": 4}  # counts are images, not tiles
    assert not np.allclose(plain.parameters.scalings, tiled.parameters.scalings)


def test_predict_with_test_tiles_averages_the_posteriors_of_the_row_and_its_own_tiles():
    table, tiles = blobs()
    frame = joined_table({"fitted": table})
    tile_frame = joined_tiles({"fitted": table}, {"fitted": tiles})
    columns = ["fitted.s_prof_1", "fitted.s_prof_2"]
    model = train_model(frame, columns, "auto", tiles=tile_frame)
    image = frame[frame["image_id"] == "twill_2"]
    own = tile_frame[tile_frame["image_id"] == "twill_2"]
    looks = pd.concat([image, own], ignore_index=True).assign(image_id=lambda t: [f"look_{k}" for k in range(len(t))])
    expected = predict(model, looks)[["p_plain", "p_twill"]].to_numpy().mean(axis=0)
    scored = predict(model, image, tile_frame)[["p_plain", "p_twill"]].to_numpy()[0]
    np.testing.assert_allclose(scored, expected, rtol=1e-12)
    assert len(own) == 4 and not np.allclose(scored, predict(model, image)[["p_plain", "p_twill"]].to_numpy()[0],
                                             rtol=1e-3, atol=0)
    # no tile of that image, or no column a tile describes: the whole row alone
    alone = predict(model, image, tile_frame[tile_frame["image_id"] != "twill_2"])
    pd.testing.assert_frame_equal(alone, predict(model, image))


def test_loocv_with_test_tiles_scores_each_image_by_its_own_looks_only(monkeypatch):
    table, tiles = blobs(n_per_class=5, seed=3)
    frame = joined_table({"fitted": table})
    tile_frame = joined_tiles({"fitted": table}, {"fitted": tiles})
    columns = ["fitted.s_prof_1", "fitted.s_prof_2"]
    scored: list[tuple[str, int]] = []
    real = loocv_module.with_own_tiles

    def spy(X, image_id, tile_rows, used):
        rows = real(X, image_id, tile_rows, used)
        scored.append((str(image_id), len(rows)))
        return rows

    monkeypatch.setattr(loocv_module, "with_own_tiles", spy)
    whole = loocv(frame, columns, "auto", subspace="none", tiles=tile_frame)
    assert scored == []  # off by default
    looked = loocv(frame, columns, "auto", subspace="none", tiles=tile_frame, test_tiles=True)
    assert scored == [(image, 5) for image in frame["image_id"]]  # the row and its own four tiles
    assert not np.allclose(whole.predictions[["p_plain", "p_twill"]], looked.predictions[["p_plain", "p_twill"]],
                           rtol=1e-3, atol=0)
    # without tile rows the switch changes nothing
    plain = loocv(frame, columns, "auto", subspace="none")
    pd.testing.assert_frame_equal(plain.predictions, loocv(frame, columns, "auto", subspace="none", test_tiles=True).predictions)
