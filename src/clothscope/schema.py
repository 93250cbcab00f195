"""JSON-Schema validation with defaults and one-line error messages.

Used for the workflow config and each sample-sheet row, so that bad input is
reported as ``<file>: <where>: <problem>`` and never as a traceback.
"""
from __future__ import annotations

import copy
import os
from pathlib import Path
from typing import Any

import jsonschema
import yaml


class InputError(ValueError):
    """Invalid user input (config or sample sheet); the message is one line."""


def load_schema(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a YAML or JSON schema file."""
    return yaml.safe_load(Path(path).read_text(encoding="utf-8"))


def fill_defaults(instance: Any, schema: dict[str, Any]) -> Any:
    """Return a copy of ``instance`` with every missing ``default`` of ``schema`` filled in."""
    if schema.get("type") != "object" or not isinstance(instance, dict):
        return instance
    filled = copy.deepcopy(instance)
    for key, sub in schema.get("properties", {}).items():
        if key not in filled and "default" in sub:
            filled[key] = copy.deepcopy(sub["default"])
        if key in filled:
            filled[key] = fill_defaults(filled[key], sub)
    return filled


def validate(instance: Any, schema: dict[str, Any], source: str) -> Any:
    """Validate ``instance`` (defaults filled first) and return the filled copy.

    Raises
    ------
    InputError
        One line: ``source: key path: message`` for the first error found.
    """
    filled = fill_defaults(instance, schema)
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(filled), key=lambda e: list(e.absolute_path))
    if errors:
        error = errors[0]
        where = ".".join(str(p) for p in error.absolute_path) or "top level"
        message = error.message.replace("\n", " ")
        raise InputError(f"{source}: {where}: {message}")
    return filled
