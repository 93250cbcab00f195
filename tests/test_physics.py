"""Physics table: transcription against the measured ArcSim files, validation, posterior weighting."""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
import yaml

from clothscope.physics.materials import (
    PhysicsEntry,
    arcsim_material_json,
    load_physics_table,
    physics_for,
    physics_table_from,
    physics_table_record,
)

ROOT = Path(__file__).resolve().parents[1]
PHYSICS_YAML = ROOT / "config" / "physics.yaml"
ARCSIM_MATERIALS = ROOT.parent / "shared" / "reference" / "arcsim_materials"
ALL_CLASSES = ["broadcloth", "canvas", "satin", "chiffon", "cotton_gauze", "knit_jersey", "velvet", "twill", "linen"]


def entry(name: str, density: float, s: float, b: float) -> PhysicsEntry:
    """An entry whose tables are constant: stretching all ``s``, bending all ``b``."""
    return PhysicsEntry(
        fabric_class=name,
        density=density,
        stretching=tuple(tuple([s] * 4) for _ in range(6)),
        bending=tuple(tuple([b] * 5) for _ in range(3)),
        source_file=f"{name}.json",
        citation="test citation",
        rationale="test",
        config_path="test.yaml",
    )


def test_committed_table_loads_and_leaves_some_classes_without_entry():
    table = load_physics_table(PHYSICS_YAML)
    assert set(table) - set(ALL_CLASSES) == {"denim"}  # a material name, for sheets labelled by material
    assert {"knit_jersey", "canvas", "twill"} <= set(table)
    assert "velvet" not in table and len(table) < len(ALL_CLASSES)
    for name, e in table.items():
        assert e.fabric_class == name and e.citation.startswith("Huamin Wang") and e.rationale
        material = arcsim_material_json(e)
        assert set(material) == {"density", "stretching", "bending"}
        assert [len(r) for r in material["stretching"]] == [4] * 6 and [len(r) for r in material["bending"]] == [5] * 3
        json.dumps(material, allow_nan=False)


@pytest.mark.skipif(not ARCSIM_MATERIALS.is_dir(), reason="measured ArcSim materials not beside the clone")
def test_transcribed_numbers_equal_source_json():
    table = load_physics_table(PHYSICS_YAML)
    assert table
    for name, e in table.items():
        source = json.loads((ARCSIM_MATERIALS / e.source_file).read_text())
        assert arcsim_material_json(e) == {k: source[k] for k in ("density", "stretching", "bending")}, name


def test_physics_for_most_likely_with_entry():
    table = {"a": entry("a", 0.1, 10.0, 1e-5), "b": entry("b", 0.3, 30.0, 3e-5)}
    out = physics_for({"a": 0.75, "b": 0.25}, table)
    assert out["most_likely_class"] == "a" and out["posterior"] == 0.75
    assert out["parameters"] == arcsim_material_json(table["a"]) and out["note"] is None
    w = out["posterior_weighted"]
    assert w["covered_mass"] == pytest.approx(1.0)
    assert w["weights"] == pytest.approx({"a": 0.75, "b": 0.25})
    # mean 0.75*0.1 + 0.25*0.3 = 0.15; std sqrt(0.75*0.05^2 + 0.25*0.15^2) = 0.0866
    assert w["density"]["mean"] == pytest.approx(0.15)
    assert w["density"]["std"] == pytest.approx(math.sqrt(0.75 * 0.05**2 + 0.25 * 0.15**2))
    assert w["stretching"]["mean"][2][3] == pytest.approx(15.0)
    assert w["stretching"]["std"][5][0] == pytest.approx(math.sqrt(0.75 * 5**2 + 0.25 * 15**2))
    assert w["bending"]["mean"][1][4] == pytest.approx(1.5e-5)
    assert [s["class"] for s in out["source"]] == ["a", "b"]
    json.dumps(out, allow_nan=False)


def test_physics_for_class_without_entry_says_so_and_renormalises():
    table = {"a": entry("a", 0.1, 10.0, 1e-5), "b": entry("b", 0.3, 30.0, 3e-5)}
    out = physics_for({"velvet": 0.6, "a": 0.1, "b": 0.3}, table)
    assert out["most_likely_class"] == "velvet" and out["parameters"] is None
    assert out["note"] == "no physics entry for class 'velvet' in test.yaml"
    w = out["posterior_weighted"]
    assert w["covered_mass"] == pytest.approx(0.4) and w["weights"] == pytest.approx({"a": 0.25, "b": 0.75})
    assert w["density"]["mean"] == pytest.approx(0.25) and w["classes_without_entry"] == ["velvet"]
    assert "0.4" in w["note"]
    json.dumps(out, allow_nan=False)


def test_physics_for_no_covered_mass():
    table = {"a": entry("a", 0.1, 10.0, 1e-5)}
    out = physics_for({"velvet": 1.0, "a": 0.0}, table)
    w = out["posterior_weighted"]
    assert out["parameters"] is None and w["covered_mass"] == 0.0
    assert w["density"] is None and "no class with a physics entry" in w["note"]
    assert out["source"] == []
    with pytest.raises(ValueError, match="sum to 1"):
        physics_for({"a": 0.5}, table)
    with pytest.raises(ValueError, match="finite"):
        physics_for({"a": float("nan"), "b": 1.0}, table)


def write_variant(tmp_path: Path, mutate) -> Path:
    raw = yaml.safe_load(PHYSICS_YAML.read_text())
    mutate(raw["classes"])
    path = tmp_path / "physics.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda c: c["canvas"].pop("density"), r"class 'canvas': missing field\(s\) density"),
        (lambda c: c["canvas"].update(density=float("nan")), r"class 'canvas': density: must be finite"),
        (lambda c: c["canvas"]["stretching"].pop(), r"class 'canvas': stretching: must be 6 rows of 4 numbers, got 5 rows"),
        (lambda c: c["knit_jersey"]["bending"][1].append(1.0), r"class 'knit_jersey': bending: row 1 must have 5 numbers"),
        (lambda c: c["knit_jersey"]["bending"][0].__setitem__(2, "1e-6"), r"class 'knit_jersey': bending\[0\]\[2\]: must be a number"),
        (lambda c: c["canvas"]["source"].pop("citation"), r"class 'canvas': source: missing field\(s\) citation"),
        (lambda c: c["canvas"].update(densty=0.2), r"class 'canvas': unknown field\(s\) densty"),
    ],
)
def test_validation_errors_name_file_and_class(tmp_path, mutate, message):
    path = write_variant(tmp_path, mutate)
    with pytest.raises(ValueError, match=message) as err:
        load_physics_table(path)
    assert str(path) in str(err.value)


def test_unreadable_table_names_file(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        load_physics_table(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("classes: [1, 2\n")
    with pytest.raises(ValueError, match="bad.yaml"):
        load_physics_table(bad)


def test_a_table_record_reads_back_to_the_same_entries_as_json(tmp_path):
    """A model folder keeps the table as JSON (physics_table_record, with where it came from); reading it back, also
    as a ``--physics`` file, loses nothing but the file name."""
    from dataclasses import replace

    table = load_physics_table(PHYSICS_YAML)
    copy = tmp_path / "physics.json"
    copy.write_text(json.dumps(physics_table_record(table) | {"from": str(PHYSICS_YAML)}, allow_nan=False))
    again = load_physics_table(copy)
    assert {name: replace(e, config_path="") for name, e in again.items()} == \
        {name: replace(e, config_path="") for name, e in table.items()}
    assert {e.config_path for e in again.values()} == {str(copy)}
    record = json.loads(copy.read_text())
    record["classes"]["canvas"]["density"] = "heavy"
    with pytest.raises(ValueError, match=r"physics.json: class 'canvas': density: must be a number"):
        physics_table_from(record, "physics.json")
