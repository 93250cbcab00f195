"""JSON-Schema validation with defaults and one-line error messages.

Used for the workflow config and each sample-sheet row, so that bad input is
reported as ``<file>: <where>: <problem>`` and never as a traceback.
"""
from __future__ import annotations

import copy
import math
import os
from pathlib import Path
from typing import Any

import yaml


class InputError(ValueError):
    """Invalid user input (config or sample sheet); the message is one line."""


#: The package's JSON Schemas: ``config.schema.yaml`` (the workflow config) and ``samples.schema.yaml`` (the sample sheet).
SCHEMA_DIR = Path(__file__).parent / "schemas"


def load_schema(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a YAML or JSON schema file."""
    return yaml.safe_load(Path(path).read_text(encoding="utf-8"))


def fill_defaults(instance: Any, schema: dict[str, Any]) -> Any:
    """Return a copy of ``instance`` with every missing ``default`` of ``schema`` filled in.

    The keys of each mapping come in the schema's order, then any the schema does not
    name: a key set to its default equals a key left out, down to the order, so a rule's
    ``params`` (which Snakemake compares as text) do not change with how a config was written.
    """
    if schema.get("type") != "object" or not isinstance(instance, dict):
        return instance
    properties = schema.get("properties", {})
    filled: dict[str, Any] = {}
    for key, sub in properties.items():
        if key in instance:
            filled[key] = fill_defaults(copy.deepcopy(instance[key]), sub)
        elif "default" in sub:
            filled[key] = fill_defaults(copy.deepcopy(sub["default"]), sub)
    filled |= {key: copy.deepcopy(value) for key, value in instance.items() if key not in properties}
    return filled


def validate(instance: Any, schema: dict[str, Any], source: str) -> Any:
    """Validate ``instance`` (defaults filled first) and return the filled copy.

    Raises
    ------
    InputError
        One line: ``source: key path: message`` for the first error found.
    """
    filled = fill_defaults(instance, schema)
    for where, value in _numbers(filled, ()):
        if not math.isfinite(value):  # JSON Schema's ranges let NaN through
            raise InputError(f"{source}: {'.'.join(where) or 'top level'}: {value!r} is not a finite number")
    import jsonschema  # imported here: a fit job reads constants of the config module and never validates

    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(filled), key=lambda e: list(e.absolute_path))
    if errors:
        error = errors[0]
        where = ".".join(str(p) for p in error.absolute_path) or "top level"
        message = error.message.replace("\n", " ")
        raise InputError(f"{source}: {where}: {message}")
    return filled


def _numbers(instance: Any, where: tuple[str, ...]):
    """``(key path, number)`` of every float in ``instance`` (nested mappings and lists)."""
    if isinstance(instance, float):
        yield where, instance
    elif isinstance(instance, dict):
        for key, value in instance.items():
            yield from _numbers(value, where + (str(key),))
    elif isinstance(instance, (list, tuple)):
        for index, value in enumerate(instance):
            yield from _numbers(value, where + (str(index),))


def deep_merge(base: dict[str, Any], override: dict[str, Any]) -> dict[str, Any]:
    """``base`` with ``override`` merged in, nested mappings merged key by key."""
    merged = dict(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = deep_merge(merged[key], value)
        else:
            merged[key] = value
    return merged


def apply_preset(config: dict[str, Any], presets_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """Merge the fidelity preset named by ``config["preset"]`` (default ``"default"``) over ``config``.

    A preset is ``<presets_dir>/<name>.yaml``; the knobs it names win over the config's.

    Raises
    ------
    InputError
        One line naming the unknown preset and the available ones.
    """
    name = str(config.get("preset", "default"))
    path = Path(presets_dir) / f"{name}.yaml"
    if not path.is_file():
        known = ", ".join(sorted(p.stem for p in Path(presets_dir).glob("*.yaml")))
        raise InputError(f"config: preset: unknown preset {name!r}; known: {known}")
    preset = yaml.safe_load(path.read_text(encoding="utf-8")) or {}
    if not isinstance(preset, dict):
        raise InputError(f"{path}: a preset must be a mapping of config sections")
    return deep_merge(config, preset)
