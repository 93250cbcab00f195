"""Every config default lives in one place, the JSON Schema ``src/clothscope/core/schemas/config.schema.yaml``.

Settings objects are built from the validated config (:func:`clothscope.core.config.settings`), so no
settings dataclass restates a default or a range, no keyword default, ``.get`` fallback or argparse default
in the code restates a config default, and ``config/config.yaml`` restates none either.

``config/config.yaml`` keeps three keys active, ``samples``, ``results`` and ``preset`` (:data:`SHOWN`): they
name a run's input, output and fidelity, the first things a user changes, and Snakemake's ``configfile:``
needs the file to be a mapping. Their values equal the schema's defaults because the file changes no
default (``test_schema_and_samples.py`` checks that); the other keys a user is likely to change are only
named in its comments, with a pointer to the schema for their defaults.
"""
from __future__ import annotations

import ast
import dataclasses

import pytest
import yaml
from conftest import ROOT

from clothscope.core.config import SECTIONS, config_schema, schema_defaults, settings, settings_class
from clothscope.core.schema import InputError

SCHEMA = config_schema()
#: config.yaml keys that may show their schema default (see the module docstring)
SHOWN = {"samples", "results", "preset"}
#: (file, function, parameter or .get key) whose literal default equals the schema default of a same-named
#: config key on purpose, reviewed by hand, each with its reason
ALLOWED = {
    # reg="auto" (Ledoit-Wolf shrinkage) is the classifier library's own default; every workflow caller passes classify.reg
    **{(f"src/clothscope/classify/{file}", function, "reg"): "library semantics" for file, function in (
        ("loocv.py", "choose_columns"), ("loocv.py", "loocv"), ("model.py", "train_model"),
        ("paper_tables.py", "paper_table"), ("paper_tables.py", "sweep"), ("qda.py", "make_qda"))},
    ("src/clothscope/core/runtime.py", "mitsuba_for", "variant"): "auto (detect the GPU) is what an unconfigured caller wants",
    ("src/clothscope/core/schema.py", "apply_preset", "preset"): "the preset is read before the config is validated",
    ("src/clothscope/fit/effects.py", "plan_stage", "full_effects"): "off is the evidence-driven plan; fit jobs pass fit.full_effects",
    **{("src/clothscope/evaluate/accuracy.py", function, "resolution"): "name collision: the scoring grid's side, not a config key"
       for function in ("fold_normal_error", "tilt_error_deg", "seen_scale")},
    ("src/clothscope/fit/outputs.py", "scene_xml", "spp"): "name collision: the preview scene's samples, not synthesize.spp",
}


def leaves(schema: dict, path: tuple = ()):
    """(dotted key, default) of every leaf of the config schema."""
    for key, sub in schema.get("properties", {}).items():
        if sub.get("type") == "object" and "properties" in sub:
            yield from leaves(sub, path + (key,))
        else:
            yield ".".join(path + (key,)), sub.get("default")


DEFAULTS = dict(leaves(SCHEMA))
BY_NAME: dict[str, list] = {}
for dotted, value in DEFAULTS.items():
    BY_NAME.setdefault(dotted.rsplit(".", 1)[-1], []).append(value)


def same(a, b) -> bool:
    """Equal as config values (a bool equals only a bool; a tuple equals the list)."""
    if isinstance(a, bool) or isinstance(b, bool):
        return type(a) is type(b) and a == b
    return (list(a) if isinstance(a, tuple) else a) == b


def node(section: str) -> dict:
    out = SCHEMA
    for key in section.split("."):
        out = out["properties"][key]
    return out


@pytest.mark.parametrize("section", SECTIONS)
def test_settings_classes_restate_no_default(section):
    cls = settings_class(section)
    with_default = [f.name for f in dataclasses.fields(cls)
                    if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING]
    assert not with_default, f"{cls.__name__} restates defaults of {section}: {with_default}"
    assert {f.name for f in dataclasses.fields(cls)} <= set(node(section)["properties"]), f"{cls.__name__} has fields the schema lacks"


@pytest.mark.parametrize("section", SECTIONS)
def test_settings_of_the_defaults_and_of_overrides(section):
    built = settings(section)
    values = schema_defaults()
    for key in section.split("."):
        values = values[key]
    assert all(same(getattr(built, f.name), values[f.name]) for f in dataclasses.fields(built))


def test_bad_overrides_are_one_line_naming_the_key():
    with pytest.raises(InputError, match=r"fit\.normals\.initial_relief"):
        settings("fit.normals", initial_relief="bumpy")
    with pytest.raises(InputError, match=r"features\.alpha: nan is not a finite number"):
        settings("features", alpha=float("nan"))
    with pytest.raises(InputError, match=r"prepare\.working_resolution"):
        settings("prepare", working_resolution=8)
    config = schema_defaults()
    config["features"]["n_peaks"] = 3
    assert settings("features", config).n_peaks == 3 and settings("features", config, n_peaks=4).n_peaks == 4


def test_enum_tuples_of_the_code_are_the_schema_enums():
    from clothscope.classify.qda import SUBSPACES
    from clothscope.core.fourier import WINDOWS
    from clothscope.core.runtime import VARIANTS
    from clothscope.features.sources import FITTED_FIELDS, NORMAL_SOURCES, PHOTO_FIELDS
    from clothscope.fit.colour import COLOUR_MODELS, LAYOUT_MIXINGS

    for values, key in ((WINDOWS, "features.window"), (VARIANTS, "variant"), (FITTED_FIELDS, "features.fitted_field"),
                        (PHOTO_FIELDS, "features.photo_field"),
                        (NORMAL_SOURCES, "features.normal_source"), (COLOUR_MODELS, "fit.normals.colour_model"),
                        (LAYOUT_MIXINGS, "fit.normals.layout_mixing"),
                        (SUBSPACES, "classify.subspace")):
        assert sorted(values) == sorted(node(key)["enum"]), key


def test_config_yaml_restates_no_default_but_the_shown_keys():
    config = yaml.safe_load((ROOT / "config/config.yaml").read_text())
    assert isinstance(config, dict)  # Snakefile's configfile: needs a mapping

    def walk(d, path=()):
        for k, v in d.items():
            if isinstance(v, dict):
                yield from walk(v, path + (k,))
            else:
                yield ".".join(path + (k,)), v

    restated = [k for k, v in walk(config) if k in DEFAULTS and same(v, DEFAULTS[k]) and k not in SHOWN]
    assert not restated, f"config/config.yaml restates {len(restated)} schema defaults: {restated}"


def python_files():
    for folder in ("src", "workflow/scripts", "workflow/benchmarks"):
        yield from sorted((ROOT / folder).rglob("*.py"))


def literal(node):
    try:
        return True, ast.literal_eval(node)
    except ValueError:
        return False, None


def restated_defaults():
    """``(file, function, name, where)`` of every literal default in the code that equals a same-named config key's."""
    for path in python_files():
        rel = str(path.relative_to(ROOT))
        tree = ast.parse(path.read_text())
        functions = [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
        owner = {id(child): f.name for f in functions for child in ast.walk(f)}
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = node.args
                pos = a.posonlyargs + a.args
                pairs = list(zip(pos[len(pos) - len(a.defaults):], a.defaults)) + list(zip(a.kwonlyargs, a.kw_defaults))
                for arg, default in pairs:
                    ok, value = literal(default) if default is not None else (False, None)
                    if ok and arg.arg in BY_NAME and any(same(value, d) for d in BY_NAME[arg.arg]):
                        yield rel, node.name, arg.arg, f"{rel}:{default.lineno} {node.name}({arg.arg}={value!r})"
            elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
                if node.func.attr in ("get", "setdefault") and len(node.args) == 2 and isinstance(node.args[0], ast.Constant) \
                        and node.args[0].value in BY_NAME:
                    ok, value = literal(node.args[1])
                    if ok and any(same(value, d) for d in BY_NAME[node.args[0].value]):
                        yield rel, owner.get(id(node), ""), node.args[0].value, f"{rel}:{node.lineno} {ast.unparse(node)}"
                elif node.func.attr == "add_argument" and node.args and isinstance(node.args[0], ast.Constant):
                    key = str(node.args[0].value).lstrip("-").replace("-", "_")
                    for kw in node.keywords:
                        ok, value = literal(kw.value) if kw.arg == "default" else (False, None)
                        if ok and key in BY_NAME and any(same(value, d) for d in BY_NAME[key]):
                            yield rel, owner.get(id(node), ""), key, f"{rel}:{node.lineno} --{key} default={value!r}"


def test_no_keyword_default_restates_a_schema_default():
    found = list(restated_defaults())
    hits = [where for rel, function, name, where in found if (rel, function, name) not in ALLOWED]
    assert not hits, f"{len(hits)} schema defaults restated:\n" + "\n".join(hits)
    stale = set(ALLOWED) - {(rel, function, name) for rel, function, name, _ in found}
    assert not stale, f"allowlisted defaults that are gone: {sorted(stale)}"
