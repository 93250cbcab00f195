"""Config schema and sample-sheet validation, and the folder-tree sheet builder."""
from __future__ import annotations

import pytest
import yaml
from conftest import ROOT, SCHEMAS

from clothscope.core.config import check_sample_counts, check_threads_across, multijitter_count
from clothscope.core.samples import load_sample_sheet, sheet_from_folder, sheet_to_tsv
from clothscope.core.schema import InputError, apply_preset, load_schema, validate

CONFIG_SCHEMA = load_schema(SCHEMAS / "config.schema.yaml")
SAMPLE_SCHEMA = SCHEMAS / "samples.schema.yaml"


def write_sheet(tmp_path, text):
    path = tmp_path / "samples.tsv"
    path.write_text(text)
    return path


def schema_keys(schema: dict, path: tuple = ()):
    """(dotted key, schema node) of every key of ``schema``, at every depth."""
    for key, node in schema.get("properties", {}).items():
        yield ".".join(path + (key,)), node
        yield from schema_keys(node, path + (key,))


def test_committed_config_is_valid_and_the_schema_documents_every_key():
    config = validate(yaml.safe_load((ROOT / "config/config.yaml").read_text()), CONFIG_SCHEMA, "config")
    assert config == validate({}, CONFIG_SCHEMA, "config")  # config/config.yaml shows keys, it changes no default
    assert config["prepare"]["working_resolution"] == 256
    undocumented = [key for key, node in schema_keys(CONFIG_SCHEMA) if "description" not in node]
    assert not undocumented, f"config keys without a description in the schema: {undocumented}"


def test_config_defaults_are_filled():
    config = validate({}, CONFIG_SCHEMA, "config")
    assert config["variant"] == "auto"
    assert config["prepare"]["clip_threshold"] == 0.98
    assert config["synthesize"]["spp"] == 64


def test_a_key_set_to_its_default_gives_the_params_text_of_a_key_left_out():
    """Snakemake compares a rule's params as text: the filled config must not depend on the order keys were written in."""
    defaults = validate({}, CONFIG_SCHEMA, "config")
    overlay = {"prepare": {"period_peak": defaults["prepare"]["period_peak"]},
               "fit": {"normals": {"spp": defaults["fit"]["normals"]["spp"]}}}
    written = validate(overlay, CONFIG_SCHEMA, "config")
    for section in ("prepare", "fit", "features", "classify"):
        assert repr(written[section]) == repr(defaults[section])
    assert list(written["prepare"]) == list(CONFIG_SCHEMA["properties"]["prepare"]["properties"])


@pytest.mark.parametrize(
    "bad, fragment",
    [
        ({"variant": "cuda_spectral"}, "variant"),
        ({"prepare": {"working_resolution": 8}}, "prepare.working_resolution"),
        ({"prepare": {"typo": 1}}, "prepare"),
        ({"unknown_key": 1}, "unknown_key"),
    ],
)
def test_config_errors_are_one_line(bad, fragment):
    with pytest.raises(InputError) as err:
        validate(bad, CONFIG_SCHEMA, "config/config.yaml")
    message = str(err.value)
    assert "\n" not in message and message.startswith("config/config.yaml") and fragment in message


def test_multijitter_counts_are_its_grids():
    """Mitsuba's multijitter sampler lays isqrt(n) columns and enough rows: 32 samples become 35."""
    assert [multijitter_count(n) for n in (1, 2, 4, 16, 30, 32, 35, 36, 64)] == [1, 2, 4, 16, 30, 35, 35, 36, 64]
    with pytest.raises(ValueError):
        multijitter_count(0)


@pytest.mark.parametrize("preset", sorted(p.stem for p in (ROOT / "config" / "presets").glob("*.yaml")))
def test_every_preset_and_the_preview_ask_for_the_samples_they_draw(preset):
    from clothscope.fit.jobs import PREVIEW_SPP

    config = validate(apply_preset({"preset": preset}, ROOT / "config" / "presets"), CONFIG_SCHEMA, "config")
    check_sample_counts(config)  # raises for a count the sampler would round up
    assert multijitter_count(PREVIEW_SPP) == PREVIEW_SPP


@pytest.mark.parametrize("stage, key", [("normals", "spp"), ("normals", "spp_grad"), ("geometry", "spp")])
def test_a_count_the_sampler_would_round_is_refused_in_one_line(stage, key):
    config = validate({"fit": {stage: {key: 32}}}, CONFIG_SCHEMA, "config")
    with pytest.raises(InputError) as err:
        check_sample_counts(config)
    assert str(err.value) == f"config: fit.{stage}.{key}: the multijitter sampler draws 35 samples per pixel when asked for 32; ask for 30 or 35"
    check_sample_counts(validate({"fit": {stage: {key: 32, "sampler": "independent"}}}, CONFIG_SCHEMA, "config"))


def test_a_field_thread_range_must_be_low_to_high_and_have_two_ends():
    check_threads_across(validate({}, CONFIG_SCHEMA, "config"))
    check_threads_across(validate({"synthesize": {"field": {"threads_across": [12, 48]}}}, CONFIG_SCHEMA, "config"))
    with pytest.raises(InputError) as err:
        check_threads_across(validate({"synthesize": {"field": {"threads_across": [48, 12]}}}, CONFIG_SCHEMA, "config"))
    assert str(err.value) == "config: synthesize.field.threads_across: [low, high] needs low < high, got [48, 12]"
    with pytest.raises(InputError):
        validate({"synthesize": {"field": {"threads_across": [12]}}}, CONFIG_SCHEMA, "config")


def test_default_sheet_loads_with_every_file(tmp_path):
    sheet = load_sample_sheet(ROOT / "config/samples.tsv", SAMPLE_SCHEMA)
    assert len(sheet) == 42 and sheet["fabric_class"].nunique() == 7


@pytest.mark.parametrize(
    "body, fragment",
    [
        ("image_id\tpath\na\t{img}\na\t{img}\n", "duplicate image_id"),
        ("image_id\tpath\tcolour\na\t{img}\tred\n", "unknown column"),
        ("image_id\tpath\nbad id\t{img}\n", "does not match"),
        ("image_id\tpath\tfabric_class\na\t{img}\tCanvas!\n", "fabric_class"),
        ("image_id\nx\n", "'path' is a required property"),
        ("image_id\tpath\n", "no rows"),
    ],
)
def test_sheet_errors_name_file_and_problem(tmp_path, body, fragment):
    img = tmp_path / "x.png"
    img.write_bytes(b"x")
    path = write_sheet(tmp_path, body.format(img=img))
    with pytest.raises(InputError) as err:
        load_sample_sheet(path, SAMPLE_SCHEMA)
    message = str(err.value)
    assert str(path) in message and fragment in message and "\n" not in message


def test_empty_class_marks_a_query(tmp_path):
    img = tmp_path / "x.png"
    img.write_bytes(b"x")
    sheet = load_sample_sheet(write_sheet(tmp_path, f"image_id\tpath\tfabric_class\nq1\t{img}\t\n"), SAMPLE_SCHEMA)
    assert sheet.loc["q1", "fabric_class"] == "" and sheet.loc["q1", "source"] == ""


def test_sheet_from_folder_tree(tmp_path):
    for rel in ("Canvas/one.png", "canvas-2/b c.jpg", "query.tif", "Satin/s1.BMP", "satin/s2.webp",
                "Canvas/one.truth-normal.png", "notes.txt"):
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_bytes(b"x")
    sheet = sheet_from_folder(tmp_path)
    assert sorted(sheet["image_id"]) == ["canvas_2_b_c", "canvas_one", "query", "satin_s1", "satin_s2"]
    assert dict(zip(sheet["image_id"], sheet["fabric_class"]))["query"] == ""
    path = write_sheet(tmp_path, sheet_to_tsv(sheet))
    assert len(load_sample_sheet(path, SAMPLE_SCHEMA)) == 5


def test_sheet_from_empty_folder_is_an_error(tmp_path):
    with pytest.raises(InputError, match="no images found"):
        sheet_from_folder(tmp_path)


def test_every_preset_is_a_valid_config_and_fast_is_cheaper():
    base = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    schema = load_schema(SCHEMAS / "config.schema.yaml")
    filled = {}
    for name in ("fast", "default", "paper"):
        filled[name] = validate(apply_preset(base | {"preset": name}, ROOT / "config" / "presets"), schema, name)
    assert filled["default"]["fit"] == validate(base, schema, "config")["fit"]
    for stage in ("geometry", "material", "normals"):
        assert filled["fast"]["fit"][stage]["iterations"] < filled["default"]["fit"][stage]["iterations"]
        assert filled["paper"]["fit"][stage]["iterations"] > filled["default"]["fit"][stage]["iterations"]
    assert filled["paper"]["fit"]["full_effects"] and not filled["default"]["fit"]["full_effects"]


def test_unknown_preset_is_one_line_naming_the_known_ones():
    with pytest.raises(InputError, match=r"unknown preset 'turbo'; known: default, fast, paper"):
        apply_preset({"preset": "turbo"}, ROOT / "config" / "presets")


def merged(base: dict, overlay: dict) -> dict:
    """``overlay`` merged over ``base`` key by key, as Snakemake merges a second ``--configfile``."""
    out = dict(base)
    for key, value in overlay.items():
        out[key] = merged(base.get(key, {}), value) if isinstance(value, dict) else value
    return out


@pytest.mark.parametrize("overlay", sorted((ROOT / "config" / "overlays").glob("*.yaml")), ids=lambda p: p.stem)
def test_every_overlay_is_a_valid_config_over_the_default(overlay):
    base = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    changes = yaml.safe_load(overlay.read_text())
    config = validate(merged(base, changes), CONFIG_SCHEMA, overlay.name)
    assert config != validate(base, CONFIG_SCHEMA, "config"), f"{overlay.name} changes nothing"
    assert overlay.read_text().lstrip().startswith("#"), f"{overlay.name} does not say what it is for"
