"""Feature rows, the feature table, the paper tables / sweep helpers, and the truth-mode workflow end to end."""
from __future__ import annotations

import json
import math
import re
import shutil
import zipfile

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
import yaml
from conftest import ROOT, SCHEMAS, SYNTHETIC, job_counts, non_finite_outputs, run_snakemake

from clothscope.classify.model import load_model
from clothscope.classify.paper_tables import PAPER_EXPERIMENTS, truncated_features
from clothscope.core.config import settings as config_settings
from clothscope.core.imageio import read_png, write_exr
from clothscope.core.schema import load_schema, validate
from clothscope.core.truth import decode_normal, truth_paths
from clothscope.features.paper import analyse_normal_map
from clothscope.features.sources import lit_normals, load_fitted, load_truth
from clothscope.features.structure import LBP_COLUMNS, STRUCTURE_COLUMNS, StructureSettings
from clothscope.features.table import (
    EXTRA_COLUMNS,
    concat_rows,
    config_hash,
    feature_row,
    feature_schema,
    features_job,
    paper_feature_columns,
    unusable_row,
    write_rows,
)

SETTINGS = config_settings("features")
FEATURE_DEFAULTS = validate({}, load_schema(SCHEMAS / "config.schema.yaml"), "config")["features"]
STRUCTURE = StructureSettings(**FEATURE_DEFAULTS["structure"])


def relief(normals):
    """A scalar field standing in for the relief behind a normal map (its x slope)."""
    return np.asarray(normals, dtype=np.float64)[..., 0]


def flat_map(size=64):
    normals = np.zeros((size, size, 3), np.float32)
    normals[..., 2] = 1.0
    return normals


def noisy_map(size=64, seed=0):
    rng = np.random.default_rng(seed)
    normals = rng.normal(0.0, 0.3, (size, size, 3))
    normals[..., 2] = 1.0
    return (normals / np.linalg.norm(normals, axis=-1, keepdims=True)).astype(np.float32)


def truth_normals(image_id="canvas_red"):
    fabric = image_id.rsplit("_", 1)[0]
    return decode_normal(read_png(truth_paths(SYNTHETIC / fabric / f"{image_id}.png")["normal"]))


@pytest.mark.parametrize("normals", [flat_map(), noisy_map()], ids=["flat", "noisy"])
@pytest.mark.parametrize("extras", [False, True])
def test_feature_row_is_finite_and_matches_schema(normals, extras):
    row = feature_row("a", "canvas", normals, relief(normals), 0.5, 0.4, SETTINGS, STRUCTURE, extras)
    schema = feature_schema(SETTINGS.n_peaks, extras)
    assert list(row) == schema.names
    numbers = [v for v in row.values() if isinstance(v, (int, float))]
    assert numbers and all(math.isfinite(v) for v in numbers)
    assert row["status"] == "ok" and row["reason"] == "" and row["specular_norm"] == pytest.approx(math.sqrt(3) * 0.4)
    assert any(c.startswith("x_") for c in row) == extras
    if normals is not None and np.ptp(normals[..., 2]) == 0:
        assert row["n_peaks"] == 0 and row["r_1"] == 0.0 and row["z_1"] == 0.0


def test_feature_row_of_a_woven_map_has_peaks():
    truth = load_truth(SYNTHETIC / "canvas" / "canvas_red.png")
    row = feature_row("canvas_red", "canvas", truth.normals, truth.field, 0.7, 0.3, SETTINGS, STRUCTURE, False)
    assert row["n_peaks"] >= 1 and row["z_1"] == pytest.approx(1.0) and 0 < row["r_1"] <= 1.0
    assert row["s_peak_fraction"] > 0.3 and row["s_prominence"] > 1.0
    assert sum(row[f"lbp_8_1_{k}"] for k in range(10)) == pytest.approx(1.0)


def test_unusable_row_is_zero_filled_with_reason():
    row = unusable_row("b", "", SETTINGS, True, "skipped", "prepare: image rejected\n(too small)")
    assert row["status"] == "skipped" and row["reason"] == "prepare: image rejected (too small)"
    assert all(row[c] == 0 for c in paper_feature_columns(2) + list(EXTRA_COLUMNS) + list(STRUCTURE_COLUMNS) + list(LBP_COLUMNS))
    with pytest.raises(ValueError):
        unusable_row("b", "", SETTINGS, False, "ok", "")


def test_table_parquet_round_trip(tmp_path):
    schema = feature_schema(3, True)
    settings = config_settings("features", n_peaks=3)
    rows = [feature_row("a", "canvas", noisy_map(), relief(noisy_map()), 0.5, 0.4, settings, STRUCTURE, True, config_hash="abc"),
            unusable_row("q", None, settings, True, "missing", "no ground truth")]
    paths = []
    for row in rows:
        paths.append(tmp_path / f"{row['image_id']}.parquet")
        write_rows([row], schema, paths[-1])
    table = concat_rows(paths)
    assert table.schema.equals(schema, check_metadata=False) and table.num_rows == 2
    back = pq.read_table(paths[0])
    assert back.schema.field("n_peaks").type == "int64" and back.schema.field("r_3").type == "double"
    frame = table.to_pandas()
    assert list(frame["status"]) == ["ok", "missing"] and frame.loc[1, "fabric_class"] == ""
    assert np.isfinite(frame.select_dtypes("number").to_numpy()).all()
    other = tmp_path / "other.parquet"
    write_rows([feature_row("c", "satin", flat_map(), relief(flat_map()), 0.2, 0.7, config_settings("features", n_peaks=2), STRUCTURE, False)],
               feature_schema(2, False), other)
    with pytest.raises(ValueError, match="schema differs"):
        concat_rows([paths[0], other])


def test_config_hash_tracks_settings_and_source_not_the_switch():
    base = {"n_peaks": 2, "alpha": 2.0, "normal_source": "fitted"}
    assert config_hash(base, "truth") == config_hash({**base, "normal_source": "truth"}, "truth")
    assert config_hash(base, "truth") != config_hash(base, "fitted")
    assert config_hash(base, "truth") != config_hash({**base, "alpha": 3.0}, "truth")
    assert config_hash(base, "photo") == config_hash({**base, "fitted_field": "shading"}, "photo")
    assert config_hash(base, "fitted") != config_hash({**base, "fitted_field": "shading"}, "fitted")
    for source in ("photo", "fitted"):
        assert config_hash(base, source) != config_hash({**base, "period_source": "prepare"}, source)
    assert config_hash(base, "truth") == config_hash({**base, "period_source": "prepare"}, "truth")


def test_truth_and_fitted_loaders(tmp_path):
    truth = load_truth(SYNTHETIC / "satin" / "satin_red.png")
    assert truth.status == "ok" and truth.normals.shape == (256, 256, 3) and 0.1 < truth.roughness < 0.4
    missing = load_truth(tmp_path / "nothing.png")
    assert missing.status == "missing" and "truth-normal.png" in missing.reason and missing.normals is None
    assert truth.field.shape == (256, 256) and np.ptp(truth.field) > 0
    # a fitted folder: raw float EXR with negative components must come back unchanged
    folder = tmp_path / "normals"
    folder.mkdir()
    normals = noisy_map(32)
    write_exr(folder / "normal.exr", normals)
    write_exr(folder / "height.exr", np.repeat(relief(normals)[..., None], 3, axis=2).astype(np.float32))
    state = {"status": "fitted", "material": {"base_color": [0.5, 0.5, 0.5], "specular": 0.4, "roughness": 0.6},
             "texels_per_pixel": 0.94, "runtime": {"mitsuba_variant": "llvm_ad_rgb"}, "scene": {"light": {"position": [0.0, 3.0, 4.0]}},
             "unexplained_share": 0.05}
    (folder / "state.json").write_text(json.dumps(state))
    fitted = load_fitted(folder, "relief")
    assert fitted.status == "ok" and fitted.mitsuba_variant == "llvm_ad_rgb" and fitted.texels_per_pixel == 0.94
    assert fitted.unexplained == pytest.approx(np.log(0.05))
    assert np.array_equal(fitted.normals, normals) and fitted.normals.min() < 0
    assert np.allclose(fitted.field, relief(normals))
    lit = load_fitted(folder, "shading")
    assert np.array_equal(lit.normals, normals)
    assert np.allclose(lit.field, np.clip(normals[..., 1] * 0.6 + normals[..., 2] * 0.8, 0, None))
    with pytest.raises(ValueError, match="fitted field must be one of relief, shading"):
        load_fitted(folder, "height")
    (folder / "state.json").write_text(json.dumps({**state, "scene": {}}))
    unlit = load_fitted(folder, "shading")
    assert unlit.status == "failed" and "KeyError" in unlit.reason and unlit.field is None
    for share, problem in ((None, "no unexplained_share"), (float("nan"), "unexplained_share is not finite")):
        older = {k: v for k, v in state.items() if k != "unexplained_share"} | ({} if share is None else {"unexplained_share": share})
        (folder / "state.json").write_text(json.dumps(older))
        unusable = load_fitted(folder, "relief")
        assert unusable.status == "failed" and problem in unusable.reason and "nan" not in unusable.reason.split(":")[0]
    (folder / "state.json").write_text(json.dumps({"status": "skipped", "reason": "prepare: rejected"}))
    skipped = load_fitted(folder, "relief")
    assert skipped.status == "skipped" and skipped.reason == "prepare: rejected"


def prepared_status(folder, status="accepted", source=256, crop=128, size=64):
    """A prepared folder holding only the status record that puts maps in its working frame."""
    folder.mkdir(parents=True, exist_ok=True)
    record = {"status": status, "source_size": [source, source], "scale": {"crop_px": crop},
              "settings": {"working_resolution": size}}
    (folder / "status.json").write_text(json.dumps(record))
    return folder


def test_truth_is_put_in_the_frame_of_the_working_photo(tmp_path):
    photo = tmp_path / "satin_red.png"
    for path in [SYNTHETIC / "satin" / "satin_red.png", *truth_paths(SYNTHETIC / "satin" / "satin_red.png").values()]:
        if path.is_file():
            shutil.copy(path, tmp_path / path.name)
    native = load_truth(photo)
    framed = load_truth(photo, prepared_status(tmp_path / "prepared"))
    assert framed.status == "ok" and framed.normals.shape == (64, 64, 3) and framed.field.shape == (64, 64)
    assert np.allclose(np.linalg.norm(framed.normals, axis=-1), 1.0, atol=1e-5)
    centre = native.field[64:192, 64:192]  # the centred 128 px, box-averaged 2 x 2
    assert np.allclose(framed.field, centre.reshape(64, 2, 64, 2).mean(axis=(1, 3)), atol=1e-5)
    assert framed.roughness == native.roughness
    # an uncropped photo at its own size, a rejected photo and a missing status keep the native maps
    for folder in (prepared_status(tmp_path / "same", crop=256, size=256), prepared_status(tmp_path / "rejected", "rejected"),
                   tmp_path / "absent"):
        kept = load_truth(photo, folder)
        assert np.array_equal(kept.normals, native.normals) and np.array_equal(kept.field, native.field)
    wrong = load_truth(photo, prepared_status(tmp_path / "other", source=512))
    assert wrong.status == "failed" and "does not match its 512x512 px photo" in wrong.reason


@pytest.mark.parametrize("position", [[0.0, 0.0, 0.0], [0.0, float("nan"), 1.0], [1.0, 2.0]])
def test_lit_normals_rejects_a_light_without_a_direction(position):
    with pytest.raises(ValueError, match="light position must be three finite numbers"):
        lit_normals(np.dstack([np.zeros((4, 4)), np.zeros((4, 4)), np.ones((4, 4))]), position)


def test_lit_normals_faces_the_light_and_clips_the_back():
    normals = np.array([[[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]])
    assert np.allclose(lit_normals(normals, [3.0, 0.0, 3.0]), [[np.sqrt(0.5), np.sqrt(0.5), 0.0]])


def test_features_job_writes_row_and_plot_for_missing_truth(tmp_path):
    image = tmp_path / "q.png"
    shutil.copy(SYNTHETIC / "canvas" / "canvas_red.png", image)
    row = features_job("q", "", "truth", str(image), None, FEATURE_DEFAULTS, str(tmp_path / "q.parquet"), str(tmp_path / "q.png.out.png"))
    assert row["status"] == "missing" and (tmp_path / "q.png.out.png").stat().st_size > 0
    assert pq.read_table(tmp_path / "q.parquet").num_rows == 1


def test_truncated_features_equal_a_fresh_analysis():
    normals = truth_normals("broadcloth_red")
    wide = analyse_normal_map(normals, config_settings("features", n_peaks=4, alpha=2.0))
    for n in (1, 2, 3):
        assert truncated_features(wide, n) == analyse_normal_map(normals, config_settings("features", n_peaks=n, alpha=2.0)).features


def test_paper_experiments_are_the_papers():
    assert [(len(e.classes), e.n_peaks, e.alpha, e.dc_radius, e.peak_size, e.paper_accuracy) for e in PAPER_EXPERIMENTS] == [
        (5, 2, 2.0, 20.0, 15.0, 0.60), (7, 2, 3.0, 20.0, 25.0, 0.38), (6, 4, 3.0, 20.0, 15.0, 0.583)]


def test_features_and_classify_config_keys_take_the_schema_defaults():
    schema = load_schema(SCHEMAS / "config.schema.yaml")
    config = validate(yaml.safe_load((ROOT / "config/config.yaml").read_text()), schema, "config")
    defaults = validate({}, schema, "config")
    assert config["features"] == defaults["features"] and config["classify"] == defaults["classify"]
    assert defaults["features"]["normal_source"] == "fitted" and defaults["features"]["extras"] is False
    assert config_settings("features", defaults) == SETTINGS


# --------------------------------------------------------------------------- the workflow, truth mode




@pytest.mark.slow
def test_truth_mode_end_to_end_and_incremental(fresh_clone, tmp_path):
    sheet = pd.read_csv(ROOT / "config" / "samples.tsv", sep="\t", dtype=str, keep_default_na=False)
    query = {"image_id": "query_canvas", "path": "data/synthetic/canvas/canvas_navy.png", "fabric_class": "", "dye_color": "",
             "source": "test query"}
    sheet = pd.concat([sheet, pd.DataFrame([query])], ignore_index=True)
    sheet_path = tmp_path / "samples.tsv"
    sheet.to_csv(sheet_path, sep="\t", index=False)
    results = tmp_path / "results"
    config = ["--config", "features={normal_source: truth}", f"samples={sheet_path}", f"results={results}"]
    # this run (43 truth and 43 photo feature rows, every report) went past a 600 s limit twice on a 2-core CI machine
    run = run_snakemake(fresh_clone, "--cores", "2", "classify_reports", "paper_reports", *config, timeout=1200)
    assert run.returncode == 0, run.stderr[-3000:]

    accuracy = json.loads((results / "reports" / "truth" / "accuracy.json").read_text())
    assert len(accuracy["classes"]) == 7 and accuracy["n"] == 42 and accuracy["n_queries"] == 1
    assert math.isfinite(accuracy["accuracy"]) and accuracy["accuracy"] >= 0.85
    table = pq.read_table(results / "features" / "truth" / "table.parquet").to_pandas()
    assert len(table) == 43 and set(table["status"]) == {"ok"} and set(table["normal_source"]) == {"truth"}
    for image_id in sheet["image_id"]:
        physics = json.loads((results / "physics" / "truth" / f"{image_id}.json").read_text())
        assert physics["status"] == "ok" and abs(sum(physics["posteriors"].values()) - 1) < 1e-6
        assert physics["physics"]["most_likely_class"] == physics["predicted_class"]
    query_physics = json.loads((results / "physics" / "truth" / "query_canvas.json").read_text())
    assert query_physics["posterior_source"] == "model" and query_physics["predicted_class"] == "canvas"
    assert query_physics["physics"]["parameters"]["density"] > 0
    predictions = pd.read_csv(results / "reports" / "truth" / "predictions.csv")
    assert predictions.loc[predictions["image_id"] == "query_canvas", "split"].item() == "query"
    paper = pd.read_csv(results / "reports" / "truth" / "paper_tables.csv")
    assert len(paper) == 6 and set(paper["status"]) == {"ok"} and list(paper["n"]) == [30, 30, 42, 42, 36, 36]
    assert "| 60% |" in (results / "reports" / "truth" / "paper_tables.md").read_text()
    assert non_finite_outputs(results) == [], "every number the pipeline writes is finite"
    report = run_snakemake(fresh_clone, "--report", str(tmp_path / "report.zip"), "classify_reports", "paper_reports", *config)
    assert report.returncode == 0, report.stderr[-3000:]
    with zipfile.ZipFile(tmp_path / "report.zip") as archive:
        names = archive.namelist()
    assert any(n.endswith("confusion.png") for n in names) and any(n.endswith("query_canvas.png") for n in names)

    # a new image (with no ground truth: marked missing, not a crash) plans only its own features job
    extra = tmp_path / "new_photo.png"
    shutil.copy(SYNTHETIC / "satin" / "satin_red.png", extra)
    grown = pd.concat([sheet, pd.DataFrame([{**query, "image_id": "new_photo", "path": str(extra)}])], ignore_index=True)
    grown.to_csv(sheet_path, sep="\t", index=False)
    dry = run_snakemake(fresh_clone, "-n", "--cores", "2", "classify_reports", "paper_reports", *config)
    assert dry.returncode == 0, dry.stderr[-3000:]
    counts = job_counts(dry.stdout)
    # its truth row, and its photo row for the feature-set comparison the classifier's summary quotes
    assert counts["features"] == 2 and counts["feature_table"] == 2 and counts["classify"] == 1
    assert re.search(r"output: \S*new_photo\.parquet", dry.stdout)


def test_classify_without_enough_labels_reports_why_instead_of_failing(tmp_path):
    from clothscope.classify.job import classify_job
    from clothscope.classify.outputs import RECORDS_FILE
    from clothscope.physics.job import physics_job

    settings = config_settings("features")
    rows = [feature_row(f"q{i}", "", noisy_map(seed=i), relief(noisy_map(seed=i)), 0.5, 0.4, settings, STRUCTURE, False)
            for i in range(3)]
    rows.append(unusable_row("bad", "canvas", settings, False, "failed", "fit_normals: diverged"))
    write_rows(rows, feature_schema(2, False), tmp_path / "table.parquet")
    physics = {r["image_id"]: str(tmp_path / "physics" / f"{r['image_id']}.json") for r in rows}
    out = classify_job(tmp_path / "table.parquet", ROOT / "config" / "physics.yaml", "truth", "auto", tmp_path / "reports",
                       tmp_path / "model", feature_set="auto", subspace="none")
    assert physics_job(tmp_path / "reports" / RECORDS_FILE, ROOT / "config" / "physics.yaml", physics) == 0
    assert out["accuracy"] is None and out["problems"]
    accuracy = json.loads((tmp_path / "reports" / "accuracy.json").read_text())
    assert accuracy["status"] == "not run" and "LOOCV" in accuracy["reason"]
    bad = json.loads((tmp_path / "physics" / "bad.json").read_text())
    assert bad["status"] == "failed" and bad["physics"] is None and bad["reason"] == "fit_normals: diverged"
    assert json.loads((tmp_path / "physics" / "q0.json").read_text())["physics"] is None
    assert json.loads((tmp_path / "model" / "model.json").read_text())["status"] == "not trained"
    with pytest.raises(ValueError, match="model.json: model was not trained: LOOCV not run"):
        load_model(tmp_path / "model")


def test_photo_loader_reads_luminance_and_skips_rejected_photos(tmp_path):
    from clothscope.features.sources import load_photo
    from clothscope.prepare.image import prepare_image

    prepare_image("a", SYNTHETIC / "canvas" / "canvas_red.png", tmp_path / "a", config_settings("prepare", working_resolution=64, scale="frame"))
    photo = load_photo(tmp_path / "a", "luminance")
    assert photo.status == "ok" and photo.field.shape == (64, 64) and photo.field is photo.normals
    assert photo.roughness == 0.0 and np.isfinite(photo.field).all() and photo.field.max() > 0
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "status.json").write_text(json.dumps({"status": "rejected", "reason": "too small"}))
    rejected = load_photo(tmp_path / "b", "luminance")
    assert rejected.status == "skipped" and "too small" in rejected.reason and rejected.field is None
    broken = load_photo(tmp_path / "missing", "luminance")
    assert broken.status == "failed" and "status.json" in broken.reason


def test_photo_shading_field_divides_out_the_dyes_and_keeps_luminance_for_algorithm_2(tmp_path):
    from clothscope.core.imageio import write_exr
    from clothscope.features.sources import load_photo
    from clothscope.prepare.image import IMAGE_FILE, STATUS_FILE

    rows, cols = np.mgrid[0:64, 0:64]
    relief = 1.0 + 0.2 * np.sin(2 * np.pi * cols / 8.0)  # threads every 8 px
    red, blue = np.array([0.6, 0.1, 0.1]), np.array([0.1, 0.1, 0.6])
    dye = np.where(((rows // 16) % 2 == 0)[..., None], red, blue)  # stripes 16 px wide across the threads
    folder = tmp_path / "striped"
    folder.mkdir()
    write_exr(folder / IMAGE_FILE, (dye * relief[..., None]).astype(np.float32))
    (folder / STATUS_FILE).write_text(json.dumps({"status": "accepted"}))
    luminance, shading = load_photo(folder, "luminance"), load_photo(folder, "shading")
    assert shading.status == "ok" and np.isfinite(shading.field).all()
    np.testing.assert_allclose(shading.normals, luminance.normals)  # Algorithm 2 reads the luminance either way
    stripe_step = lambda f: abs(f[rows // 16 % 2 == 0].mean() / f[rows // 16 % 2 == 1].mean() - 1)  # noqa: E731
    assert stripe_step(luminance.field) > 0.5 and stripe_step(shading.field) < 0.01
    np.testing.assert_allclose(shading.field / shading.field.mean(), relief / relief.mean(), atol=1e-3)
    with pytest.raises(ValueError, match="photo field must be one of luminance, shading"):
        load_photo(folder, "albedo")


def test_the_descriptor_takes_the_period_prepare_measured_in_its_maps_pixels(tmp_path):
    from clothscope.features.sources import descriptor_period, prepared_period
    from clothscope.prepare.image import STATUS_FILE

    folder = tmp_path / "prepared"
    folder.mkdir()
    (folder / STATUS_FILE).write_text(json.dumps({"status": "accepted", "scale": {"working_period_px": 12.5}}))
    assert prepared_period(folder) == 12.5
    assert descriptor_period("photo", folder, 1.0, "auto") is None  # no sizes recorded: the map's own
    assert descriptor_period("photo", folder, 1.0, "prepare") == 12.5
    assert descriptor_period("fitted", folder, 0.94, "prepare") == pytest.approx(12.5 * 0.94)  # texels per working pixel
    assert descriptor_period("fitted", folder, 0.94, "field") is None
    assert descriptor_period("truth", folder, 1.0, "prepare") is None and descriptor_period("photo", None, 1.0, "prepare") is None
    for side, expected in ((256, None), (1024, 12.5)):  # auto: prepare's period only where it saw more pixels than the map
        status = {"status": "accepted", "scale": {"working_period_px": 12.5}, "source_size": [side, 2000],
                  "settings": {"working_resolution": 256}}
        (folder / STATUS_FILE).write_text(json.dumps(status))
        assert descriptor_period("photo", folder, 1.0, "auto") == expected and descriptor_period("photo", folder, 1.0, "prepare") == 12.5
    with pytest.raises(ValueError, match="period source must be one of field, prepare, auto"):
        descriptor_period("photo", folder, 1.0, "native")
    for scale in ({"method": "frame"}, {"working_period_px": None}, {"working_period_px": "NaN"}, {"working_period_px": -1}, None):
        (folder / STATUS_FILE).write_text(json.dumps({"status": "accepted", "scale": scale}))
        assert prepared_period(folder) is None  # no lattice found, or the whole frame scaled: the map's own period
    (folder / STATUS_FILE).write_text("{broken")
    assert prepared_period(folder) is None and prepared_period(tmp_path / "missing") is None


def test_features_job_reads_the_photo_at_the_period_prepare_measured(tmp_path):
    from clothscope.prepare.image import STATUS_FILE, prepare_image

    prepare_image("a", SYNTHETIC / "canvas" / "canvas_red.png", tmp_path / "a", config_settings("prepare", working_resolution=128, scale="frame"))
    rows = {}
    for name, period, source in (("own", None, "field"), ("given", 20.0, "prepare")):
        status = json.loads((tmp_path / "a" / STATUS_FILE).read_text())
        status["scale"]["working_period_px"] = period
        (tmp_path / "a" / STATUS_FILE).write_text(json.dumps(status))
        settings = {**FEATURE_DEFAULTS, "period_source": source}
        rows[name] = features_job("a", "canvas", "photo", "x.png", str(tmp_path / "a"), settings, str(tmp_path / f"{name}.parquet"),
                                  str(tmp_path / f"{name}.png"), prepared_dir=str(tmp_path / "a"))
    assert rows["own"]["status"] == rows["given"]["status"] == "ok"
    assert rows["own"]["s_prof_1"] != rows["given"]["s_prof_1"] and rows["own"]["r_1"] == rows["given"]["r_1"]
    assert all(math.isfinite(v) for v in rows["given"].values() if isinstance(v, float))


def test_physics_job_refuses_records_and_outputs_that_name_other_images(tmp_path):
    from clothscope.physics.job import physics_job

    records = tmp_path / "records.json"
    records.write_text(json.dumps([{"image_id": "a", "posteriors": None}]))
    with pytest.raises(ValueError, match="records.json: no physics output path for image.s. a"):
        physics_job(records, ROOT / "config" / "physics.yaml", {"b": str(tmp_path / "b.json")})
    with pytest.raises(ValueError, match="records.json: the feature table has no row for image.s. b"):
        physics_job(records, ROOT / "config" / "physics.yaml", {"a": str(tmp_path / "a.json"), "b": str(tmp_path / "b.json")})
    assert not (tmp_path / "a.json").exists()
