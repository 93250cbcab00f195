"""The workflow config's defaults, and settings objects built from a validated config.

Every default and range of the config lives in one place, the JSON Schema
``clothscope/core/schemas/config.schema.yaml`` (package data, so an installed
package has it too); the settings dataclasses restate none of them.
"""
from __future__ import annotations

import copy
import dataclasses
import functools
import importlib
import math
from collections.abc import Mapping
from typing import Any

from clothscope.core.schema import SCHEMA_DIR, InputError, deep_merge, load_schema, validate

#: The config schema.
SCHEMA_PATH = SCHEMA_DIR / "config.schema.yaml"

#: The fit stages, each a ``fit.<stage>`` section with ``spp`` and ``sampler``.
FIT_STAGES = ("geometry", "material", "normals")

#: Config section (dotted) -> its settings class, ``module:Class``, imported when first asked for.
SECTIONS = {
    "prepare": "clothscope.prepare.image:PrepareSettings",
    "fit.geometry": "clothscope.fit.geometry:GeometrySettings",
    "fit.material": "clothscope.fit.material:MaterialSettings",
    "fit.normals": "clothscope.fit.normals:NormalSettings",
    "features": "clothscope.features.paper:SpectrumSettings",  # its fields are a subset of the section's keys
    "features.structure": "clothscope.features.structure:StructureSettings",
}


@functools.cache
def _schema() -> dict[str, Any]:
    return load_schema(SCHEMA_PATH)


def config_schema() -> dict[str, Any]:
    """The config schema, read from :data:`SCHEMA_PATH` (a fresh copy)."""
    return copy.deepcopy(_schema())


def schema_defaults() -> dict[str, Any]:
    """The config every key of which takes its schema default (a fresh dict on each call)."""
    return validate({}, _schema(), "schema defaults")


def settings_class(section: str) -> type:
    """The settings dataclass of a config ``section`` (a key of :data:`SECTIONS`)."""
    module, name = SECTIONS[section].split(":")
    return getattr(importlib.import_module(module), name)


def settings(section: str, config: Mapping[str, Any] | None = None, /, **overrides: Any) -> Any:
    """The settings object of a config section.

    Parameters
    ----------
    section : str
        Dotted config section, a key of :data:`SECTIONS` (``"fit.normals"``).
    config : mapping, optional
        A whole config; None takes the schema's defaults.
    **overrides
        Keys of the section that replace the config's.

    Returns
    -------
    object
        An instance of the section's settings class.

    Raises
    ------
    clothscope.core.schema.InputError
        One line naming the key, when the config with the overrides breaks the schema.
    """
    keys = section.split(".")
    nested: dict[str, Any] = dict(overrides)
    for key in reversed(keys):
        nested = {key: nested}
    merged = validate(deep_merge(dict(schema_defaults() if config is None else config), nested), _schema(),
                      f"settings({section!r})")
    values = merged
    for key in keys:
        values = values[key]
    cls = settings_class(section)
    return cls(**{field.name: values[field.name] for field in dataclasses.fields(cls)})


def multijitter_count(spp: int) -> int:
    """Samples per pixel Mitsuba's ``multijitter`` sampler draws when asked for ``spp``.

    It lays a grid of ``isqrt(spp)`` columns and as many rows as ``spp`` needs, so
    a count that is not such a grid is rounded up (32 becomes 35, 5 x 7).
    """
    if spp < 1:
        raise ValueError(f"a sample count must be >= 1, got {spp}")
    columns = math.isqrt(spp)
    return columns * -(-spp // columns)


def check_sample_counts(config: Mapping[str, Any]) -> None:
    """Refuse a fit stage's sample count that its ``multijitter`` sampler would round up unasked.

    Raises
    ------
    InputError
        One line naming the first ``fit.<stage>.spp`` or ``spp_grad`` concerned, the count the
        sampler would draw and the nearest counts it draws as asked.
    """
    for stage in FIT_STAGES:
        section = config["fit"][stage]
        if section["sampler"] != "multijitter":
            continue
        for key in ("spp", "spp_grad"):
            asked = int(section.get(key, 0))
            if asked and multijitter_count(asked) != asked:
                below = next(n for n in range(asked - 1, 0, -1) if multijitter_count(n) == n)
                raise InputError(f"config: fit.{stage}.{key}: the multijitter sampler draws {multijitter_count(asked)} "
                                 f"samples per pixel when asked for {asked}; ask for {below} or {multijitter_count(asked)}")


def check_threads_across(config: Mapping[str, Any]) -> None:
    """Refuse a ``synthesize.field.threads_across`` whose low end is not below its high end (the schema cannot say it).

    Raises
    ------
    InputError
        One line naming the key and the values.
    """
    span = list(config["synthesize"]["field"].get("threads_across") or [])
    if span and not span[0] < span[1]:
        raise InputError(f"config: synthesize.field.threads_across: [low, high] needs low < high, got {span}")
