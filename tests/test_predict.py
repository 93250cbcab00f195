"""``clothscope predict``: photos in, one line each out, with a model the workflow's classify stage saves."""
from __future__ import annotations

import json
import math

import pandas as pd
import pytest
import yaml
from conftest import ROOT, SCHEMAS, SYNTHETIC

from clothscope.classify.feature_sets import classifier_candidates, joined_table
from clothscope.classify.model import load_model, save_model, train_model
from clothscope.cli import main
from clothscope.core.config import schema_defaults
from clothscope.core.schema import apply_preset, load_schema, validate
from clothscope.features.structure import StructureSettings
from clothscope.features.table import features_job
from clothscope.classify.outputs import MODEL_PHYSICS_FILE
from clothscope.physics.job import physics_job
from clothscope.predict import model_physics_table, model_sources, scored_with_tiles, training_settings, unique_ids
from clothscope.prepare.image import PrepareSettings, prepare_image

CLASSES = ("canvas", "satin", "velvet")
TRAIN_COLORS = ("charcoal", "green", "ivory", "mustard")
HELD_OUT = SYNTHETIC / "satin" / "satin_red.png"


def default_settings() -> dict:
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    config = validate(apply_preset(config, ROOT / "config" / "presets"), load_schema(SCHEMAS / "config.schema.yaml"), "config")
    return {key: config[key] for key in ("prepare", "fit", "features", "variant")}


@pytest.fixture(scope="module")
def photo_model(tmp_path_factory):
    """A model on photo-only LBP features of 12 embedded images, saved as the classify rule saves one."""
    work = tmp_path_factory.mktemp("train")
    settings = default_settings()
    rows = []
    for fabric in CLASSES:
        for color in TRAIN_COLORS:
            image_id, path = f"{fabric}_{color}", SYNTHETIC / fabric / f"{fabric}_{color}.png"
            prepare_image(image_id, path, work / image_id, PrepareSettings(**settings["prepare"]),
                          StructureSettings(**settings["features"]["structure"]))
            rows.append(features_job(image_id, fabric, "photo", str(path), str(work / image_id), settings["features"],
                                     str(work / f"{image_id}.parquet"), str(work / f"{image_id}.png")))
    table = joined_table({"photo": pd.DataFrame(rows)})
    columns = classifier_candidates("lbp", "photo", table.columns)["lbp"]
    folder = work / "model"
    save_model(train_model(table, columns, "auto", "discriminant"), folder,
               {"normal_source": "photo", "settings": settings, "physics_table": "config/physics.yaml"})
    (work / "records.json").write_text("[]")  # the physics rule keeps the table beside the model
    physics_job(work / "records.json", ROOT / "config" / "physics.yaml", {}, table_copy=folder / MODEL_PHYSICS_FILE)
    return folder


def test_predict_prints_a_class_per_photo_and_a_reason_per_bad_one(photo_model, tmp_path, capsys):
    bad = tmp_path / "notes.png"
    bad.write_text("not an image")
    code = main(["predict", str(HELD_OUT), str(bad), str(tmp_path / "missing.jpg"), "--model", str(photo_model),
                 "--out", str(tmp_path / "out"), "--quiet"])
    printed = capsys.readouterr()
    lines = printed.out.strip().splitlines()
    assert code == 0 and len(lines) == 3
    photo, predicted, posterior, physics_path = lines[0].split("\t")
    assert photo == str(HELD_OUT) and predicted in CLASSES and 0 < float(posterior) <= 1
    record = json.loads(open(physics_path).read())
    # the held-out satin's threads are about 7 px even at native resolution, under the 8-16 px band: prepare says so
    assert record["prepare_note"].startswith("threads are") and record["prepare_note"].endswith("photograph closer")
    assert f"clothscope: note: {HELD_OUT}: {record['prepare_note']}" in printed.err.splitlines()
    assert record["predicted_class"] == predicted and math.isclose(sum(record["posteriors"].values()), 1.0)
    assert record["physics"]["parameters"]["bending"] and not list((tmp_path / "out").rglob(".*tmp*"))
    assert lines[1].startswith(f"{bad}\tnot classified\t{bad}") and "\n" not in lines[1]
    assert lines[2].startswith(f"{tmp_path / 'missing.jpg'}\tnot classified\t") and "does not exist" in lines[2]
    assert not (tmp_path / "out" / "satin_red" / "fit").exists(), "a photo-feature model must not run the fit"
    assert record["fit"] is None


def test_predict_fails_only_when_no_photo_is_classified(photo_model, tmp_path, capsys):
    bad = tmp_path / "empty.png"
    bad.write_bytes(b"")
    assert main(["predict", str(bad), "--model", str(photo_model), "--out", str(tmp_path / "out"), "--quiet"]) == 1
    assert "not classified" in capsys.readouterr().out


def test_predict_without_a_model_says_how_to_make_one(tmp_path, capsys):
    assert main(["predict", str(HELD_OUT), "--model", str(tmp_path / "none"), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("clothscope: error: ") and "classify rule" in err and len(err.splitlines()) == 1


def test_a_model_copied_elsewhere_classifies_from_any_directory_with_its_own_physics_table(photo_model, tmp_path,
                                                                                          monkeypatch, capsys):
    """The model folder keeps a copy of the physics table (physics.json), so the path it was trained with ("config/physics.yaml",
    relative to the clone) need not exist where ``predict`` runs."""
    import shutil

    moved = tmp_path / "elsewhere" / "model"
    shutil.copytree(photo_model, moved)
    monkeypatch.chdir(tmp_path)
    assert main(["predict", str(HELD_OUT), "--model", str(moved), "--out", str(tmp_path / "out"), "--quiet"]) == 0
    physics_path = capsys.readouterr().out.strip().split("\t")[3]
    assert json.loads(open(physics_path).read())["physics"]["parameters"]["bending"]


def test_a_model_folder_without_its_physics_table_says_to_pass_one(photo_model, tmp_path, monkeypatch):
    import shutil

    old = tmp_path / "old"
    shutil.copytree(photo_model, old)
    (old / MODEL_PHYSICS_FILE).unlink()
    model = load_model(old)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError, match=r"physics.json: does not exist, .*\(config/physics.yaml\) .*pass --physics"):
        model_physics_table(model, old)
    assert set(model_physics_table(model, old, str(ROOT / "config" / "physics.yaml"))) >= {"canvas"}
    (old / MODEL_PHYSICS_FILE).write_text('{"classes": {"canvas": {"density": 0.2}}}')
    with pytest.raises(ValueError, match=r"physics.json: class 'canvas': missing field"):
        model_physics_table(model, old)


def test_model_sources_puts_the_models_own_source_first(photo_model):
    model = load_model(photo_model)
    assert model_sources(model) == ["photo"]
    next(iter(model.members.values())).feature_columns = ["photo.s_a", "fitted.s_a"]
    model.metadata["metadata"]["normal_source"] = "fitted"
    assert model_sources(model) == ["fitted", "photo"]


def test_a_model_recorded_before_fitted_field_reads_the_relief(photo_model):
    model = load_model(photo_model)
    assert training_settings(model)["features"]["fitted_field"] == "relief"
    del model.metadata["metadata"]["settings"]["features"]["fitted_field"]
    assert training_settings(model)["features"]["fitted_field"] == "relief"


def test_unique_ids_are_safe_and_distinct():
    assert unique_ids(["a/x y.png", "b/x y.png", "c/.hidden.jpg"]) == ["x_y", "x_y_2", "hidden"]


def tiny_fit_model(photo_model, folder, source: str):
    """The photo model re-saved with tiny fit settings, reading ``source`` (``photo`` or ``fitted``) columns."""
    model = load_model(photo_model)
    settings = model.metadata["metadata"]["settings"]
    tiny = {"geometry": {"resolution": 32, "spp": 2, "iterations": 3},
            "material": {"resolution": 32, "spp": 1, "iterations": 2},
            "normals": {"resolution": 64, "texture": 64, "spp": 1, "spp_grad": 1, "iterations": 2, "joint_iterations": 2}}
    for stage, knobs in tiny.items():
        settings["fit"][stage].update(knobs)
    for member in model.members.values():
        member.feature_columns = [c.replace("photo.", f"{source}.") for c in member.feature_columns]
    save_model(model, folder, {**model.metadata["metadata"], "normal_source": source, "settings": settings})
    return folder


def assert_fitted(out, image_id: str) -> None:
    for stage in ("geometry", "material", "normals"):
        state = json.loads((out / image_id / "fit" / stage / "state.json").read_text())
        assert state["status"] == "fitted", state


@pytest.mark.slow
def test_predict_fits_the_photo_when_the_model_reads_fitted_maps(photo_model, tmp_path, capsys):
    """A model over fitted-map columns runs the three fit stages (tiny settings) before its features."""
    folder = tiny_fit_model(photo_model, tmp_path / "fitted_model", "fitted")
    assert main(["predict", str(HELD_OUT), "--model", str(folder), "--out", str(tmp_path / "out"), "--quiet",
                 "--threads", "1"]) == 0
    photo, predicted, _, _ = capsys.readouterr().out.strip().split("\t")
    assert predicted in CLASSES
    assert_fitted(tmp_path / "out", "satin_red")


@pytest.mark.slow
def test_predict_with_render_fits_the_photo_for_a_photo_model_and_names_the_fit(photo_model, tmp_path, capsys):
    """``--render`` runs the fit although the model reads only the photo; physics.json points at its normal-map stage."""
    folder = tiny_fit_model(photo_model, tmp_path / "photo_model", "photo")
    assert main(["predict", str(HELD_OUT), "--model", str(folder), "--out", str(tmp_path / "out"), "--quiet",
                 "--threads", "1", "--render"]) == 0
    physics_path = capsys.readouterr().out.strip().split("\t")[3]
    assert_fitted(tmp_path / "out", "satin_red")
    fit = json.loads(open(physics_path).read())["fit"]
    assert fit == str(tmp_path / "out" / "satin_red" / "fit" / "normals") and (tmp_path / "out" / "satin_red" / "fit" / "normals" / "material.json").is_file()


def test_a_model_recorded_before_a_key_takes_its_legacy_value_else_the_schema_default(photo_model):
    model = load_model(photo_model)
    recorded = model.metadata["metadata"]["settings"]
    del recorded["prepare"]["scale"], recorded["fit"]["normals"]["colour_model"], recorded["features"]["n_peaks"]
    del recorded["fit"]["normals"]["layout_mixing"]
    settings = training_settings(model)
    assert settings["prepare"]["scale"] == "frame" and settings["fit"]["normals"]["colour_model"] == "one_colour"
    assert settings["fit"]["normals"]["layout_mixing"] == "hard"
    assert settings["features"]["n_peaks"] == schema_defaults()["features"]["n_peaks"]


def test_a_model_scored_with_tiles_scores_a_photo_by_its_row_and_its_tiles(photo_model, tmp_path, capsys):
    model = load_model(photo_model)
    assert not scored_with_tiles(model)  # a record without the key: the whole row, as before the key existed
    folder = tmp_path / "tiled"
    save_model(model, folder, {**model.metadata["metadata"], "test_tiles": "mean"})
    assert scored_with_tiles(load_model(folder))
    posteriors = {}
    for name, model_folder in (("whole", photo_model), ("tiles", folder)):
        assert main(["predict", str(HELD_OUT), "--model", str(model_folder), "--out", str(tmp_path / name), "--quiet"]) == 0
        record = json.loads((tmp_path / name / "satin_red" / "physics.json").read_text())
        posteriors[name] = record["posteriors"]
        assert math.isclose(sum(record["posteriors"].values()), 1.0)
    capsys.readouterr()
    assert len(pd.read_parquet(tmp_path / "tiles" / "satin_red" / "features" / "photo.tiles.parquet")) == 9
    assert not (tmp_path / "whole" / "satin_red" / "features" / "photo.tiles.parquet").exists()
    assert posteriors["whole"] != posteriors["tiles"]
