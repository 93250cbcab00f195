"""From fabric class to cloth-simulation parameters (ArcSim's material format).

``config/physics.yaml`` maps a fabric class to measured material data of
Wang, Ramamoorthi and O'Brien (2011) in ArcSim's format: an area ``density``,
a 6 x 4 ``stretching`` table and a 3 x 5 ``bending`` table, with the source
file and a rationale. Classes without a defensible measured analogue have
no entry; :func:`physics_for` says so instead of inventing numbers.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

#: Shapes of the ArcSim material tables (rows, numbers per row).
STRETCHING_SHAPE = (6, 4)
BENDING_SHAPE = (3, 5)
ENTRY_FIELDS = {"density", "stretching", "bending", "source", "rationale"}
SOURCE_FIELDS = {"file", "citation", "fabric"}
#: Posteriors must sum to 1 within this tolerance.
POSTERIOR_SUM_TOL = 1e-6


@dataclass(frozen=True)
class PhysicsEntry:
    """Measured ArcSim material of one fabric class, with its provenance."""

    fabric_class: str
    density: float
    stretching: tuple[tuple[float, ...], ...]
    bending: tuple[tuple[float, ...], ...]
    source_file: str
    citation: str
    rationale: str
    fabric: str = ""
    config_path: str = ""


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        hint = " (YAML reads e.g. 1e-6 as text: write 1.0e-6)" if isinstance(value, str) else ""
        raise ValueError(f"{where}: must be a number, got {value!r}{hint}")
    if not math.isfinite(value):
        raise ValueError(f"{where}: must be finite, got {value!r}")
    return float(value)


def _table(value: Any, shape: tuple[int, int], where: str) -> tuple[tuple[float, ...], ...]:
    rows, cols = shape
    if not isinstance(value, list) or len(value) != rows:
        got = f"{len(value)} rows" if isinstance(value, list) else type(value).__name__
        raise ValueError(f"{where}: must be {rows} rows of {cols} numbers, got {got}")
    table = []
    for i, row in enumerate(value):
        if not isinstance(row, list) or len(row) != cols:
            got = f"{len(row)} numbers" if isinstance(row, list) else type(row).__name__
            raise ValueError(f"{where}: row {i} must have {cols} numbers, got {got}")
        table.append(tuple(_number(x, f"{where}[{i}][{j}]") for j, x in enumerate(row)))
    return tuple(table)


def _text(value: Any, where: str) -> str:
    if not isinstance(value, str) or not value.strip():
        raise ValueError(f"{where}: must be a non-empty string, got {value!r}")
    return value.strip()


def _entry(fabric_class: str, raw: Any, path: str) -> PhysicsEntry:
    where = f"{path}: class {fabric_class!r}"
    if not isinstance(raw, dict):
        raise ValueError(f"{where}: entry must be a mapping, got {type(raw).__name__}")
    missing = sorted(ENTRY_FIELDS - raw.keys())
    if missing:
        raise ValueError(f"{where}: missing field(s) {', '.join(missing)}")
    unknown = sorted(set(raw) - ENTRY_FIELDS)
    if unknown:
        raise ValueError(f"{where}: unknown field(s) {', '.join(map(str, unknown))}; allowed: {', '.join(sorted(ENTRY_FIELDS))}")
    density = _number(raw["density"], f"{where}: density")
    if density <= 0:
        raise ValueError(f"{where}: density must be > 0, got {density}")
    source = raw["source"]
    if not isinstance(source, dict):
        raise ValueError(f"{where}: source must be a mapping with file and citation, got {source!r}")
    missing = sorted({"file", "citation"} - source.keys())
    if missing:
        raise ValueError(f"{where}: source: missing field(s) {', '.join(missing)}")
    unknown = sorted(set(source) - SOURCE_FIELDS)
    if unknown:
        raise ValueError(f"{where}: source: unknown field(s) {', '.join(map(str, unknown))}")
    return PhysicsEntry(
        fabric_class=fabric_class,
        density=density,
        stretching=_table(raw["stretching"], STRETCHING_SHAPE, f"{where}: stretching"),
        bending=_table(raw["bending"], BENDING_SHAPE, f"{where}: bending"),
        source_file=_text(source["file"], f"{where}: source.file"),
        citation=_text(source["citation"], f"{where}: source.citation"),
        fabric=_text(source["fabric"], f"{where}: source.fabric") if "fabric" in source else "",
        rationale=_text(raw["rationale"], f"{where}: rationale"),
        config_path=str(path),
    )


def load_physics_table(path: str | os.PathLike[str]) -> dict[str, PhysicsEntry]:
    """Read and validate the physics table (``config/physics.yaml``).

    Parameters
    ----------
    path
        YAML file with a ``classes:`` mapping of fabric class to entry.

    Returns
    -------
    dict
        Fabric class to :class:`PhysicsEntry`; classes without an entry are absent.

    Raises
    ------
    ValueError
        One line naming the file, the class and the field that is missing,
        non-finite, of the wrong type or of the wrong shape.
    """
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ValueError(f"{path}: physics table does not exist") from None
    except (yaml.YAMLError, UnicodeDecodeError) as err:
        raise ValueError(f"{path}: not readable YAML: {str(err).splitlines()[0]}") from None
    return physics_table_from(raw, str(path))


def physics_table_from(raw: Any, where: str) -> dict[str, PhysicsEntry]:
    """Validate a physics table already read (the YAML's mapping, or :func:`physics_table_record`'s).

    An optional top-level ``from`` (the file a model folder's copy was read
    from) is ignored. ``where`` names it in every message (a file, or a model record). Raises
    ``ValueError`` as :func:`load_physics_table` does.
    """
    if not isinstance(raw, dict) or "classes" not in raw:
        raise ValueError(f"{where}: expected a mapping with a 'classes:' key")
    unknown = sorted(set(raw) - {"classes", "from"})  # "from": where the physics rule read a model folder's copy
    if unknown:
        raise ValueError(f"{where}: unknown top-level key(s) {', '.join(map(str, unknown))}")
    classes = raw["classes"] or {}
    if not isinstance(classes, dict):
        raise ValueError(f"{where}: 'classes' must be a mapping of fabric class to entry")
    return {str(name): _entry(str(name), entry, where) for name, entry in classes.items()}


def physics_table_record(table: dict[str, PhysicsEntry]) -> dict[str, Any]:
    """The table as JSON-ready data that :func:`physics_table_from` reads back to the same entries.

    The ``physics`` rule keeps it beside a trained model, so ``clothscope
    predict`` needs no path to the YAML it came from.
    """
    def source(entry: PhysicsEntry) -> dict[str, str]:
        return {"file": entry.source_file, "citation": entry.citation} | ({"fabric": entry.fabric} if entry.fabric else {})

    return {"classes": {name: {"density": entry.density, "stretching": [list(row) for row in entry.stretching],
                               "bending": [list(row) for row in entry.bending], "source": source(entry),
                               "rationale": entry.rationale}
                        for name, entry in table.items()}}


def arcsim_material_json(entry: PhysicsEntry) -> dict[str, Any]:
    """The entry as an ArcSim material file: ``{"density", "stretching", "bending"}``.

    Write it to e.g. ``materials/<class>.json`` and point an ArcSim config's
    ``"materials": [{"data": "materials/<class>.json"}]`` at it.
    """
    return {
        "density": float(entry.density),
        "stretching": [list(map(float, row)) for row in entry.stretching],
        "bending": [list(map(float, row)) for row in entry.bending],
    }


def _check_posteriors(posteriors: dict[str, float]) -> dict[str, float]:
    if not isinstance(posteriors, dict) or not posteriors:
        raise ValueError("posteriors must be a non-empty mapping of fabric class to probability")
    checked = {}
    for name, value in posteriors.items():
        p = _number(value, f"posterior of {name!r}")
        if p < 0:
            raise ValueError(f"posterior of {name!r} is negative: {p}")
        checked[str(name)] = p
    total = sum(checked.values())
    if abs(total - 1.0) > POSTERIOR_SUM_TOL:
        raise ValueError(f"posteriors must sum to 1, got {total}")
    return checked


def _table_name(table: dict[str, PhysicsEntry]) -> str:
    paths = sorted({e.config_path for e in table.values() if e.config_path})
    return " / ".join(paths) if paths else "the physics table"


def _source(entry: PhysicsEntry) -> dict[str, str]:
    return {"class": entry.fabric_class, "file": entry.source_file, "fabric": entry.fabric, "citation": entry.citation}


def _weighted(values: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted mean and (population) standard deviation over axis 0."""
    w = weights.reshape((-1,) + (1,) * (values.ndim - 1))
    mean = (w * values).sum(axis=0)
    var = (w * (values - mean) ** 2).sum(axis=0)
    return mean, np.sqrt(np.maximum(var, 0.0))


def physics_for(posteriors: dict[str, float], table: dict[str, PhysicsEntry]) -> dict[str, Any]:
    """Simulation parameters for a classified image, JSON-ready.

    Parameters
    ----------
    posteriors
        Fabric class to posterior probability (sums to 1).
    table
        From :func:`load_physics_table`.

    Returns
    -------
    dict
        ``most_likely_class`` and its ``posterior``; ``parameters``: the ArcSim
        material of that class, or ``None`` with a plain ``note`` when it has
        no entry; ``posterior_weighted``: mean and standard deviation of
        density and of every stretching and bending number over the classes
        that have entries, weights renormalised over them, with the
        ``covered_mass`` they hold (means are ``None`` with a note when it
        is 0); ``source``: citations of every entry used.
    """
    posteriors = _check_posteriors(posteriors)
    best = max(sorted(posteriors), key=lambda c: posteriors[c])
    name = _table_name(table)
    entry = table.get(best)
    covered = sorted(c for c in posteriors if c in table and posteriors[c] > 0)
    mass = float(sum(posteriors[c] for c in covered))
    uncovered = sorted(c for c in posteriors if c not in table)

    weighted: dict[str, Any] = {
        "covered_mass": mass,
        "weights": {},
        "classes_without_entry": uncovered,
        "density": None,
        "stretching": None,
        "bending": None,
        "note": None,
    }
    if mass > 0:
        weights = np.array([posteriors[c] for c in covered]) / mass
        weighted["weights"] = {c: float(w) for c, w in zip(covered, weights)}
        for key in ("density", "stretching", "bending"):
            values = np.array([getattr(table[c], key) for c in covered], dtype=float)
            mean, std = _weighted(values, weights)
            weighted[key] = {"mean": mean.tolist(), "std": std.tolist()}
        if uncovered and mass < 1.0:
            weighted["note"] = (
                f"weights renormalised over classes with a physics entry, which hold {mass:.3g} of the posterior mass; "
                f"no entry for {', '.join(map(repr, uncovered))}"
            )
    else:
        weighted["note"] = f"no class with a physics entry in {name} has posterior mass; no weighted parameters"

    used = sorted(set(covered) | ({best} if entry is not None else set()))
    return {
        "most_likely_class": best,
        "posterior": posteriors[best],
        "parameters": arcsim_material_json(entry) if entry is not None else None,
        "note": None if entry is not None else f"no physics entry for class {best!r} in {name}",
        "posterior_weighted": weighted,
        "source": [_source(table[c]) for c in used],
    }
