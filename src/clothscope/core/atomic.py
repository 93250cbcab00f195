"""Atomic output helpers: a file appears whole or not at all.

Every writer in the package goes through these, so an interrupted run never
leaves a half-written file that a rerun would trust.
"""
from __future__ import annotations

import json
import math
import os
import re
import shutil
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any


def stale_temporaries(target: Path) -> list[Path]:
    """Temporary files and folders an interrupted writer of ``target`` left beside it.

    Only names this module makes for ``target`` itself match (``.<name>.<8 random
    characters>.tmp[<suffix>]``), never those of a sibling whose name merely starts
    with ``<name>.``.
    """
    pattern = re.compile(rf"^\.{re.escape(target.name)}\.[a-z0-9_]{{8}}\.tmp{re.escape(target.suffix)}$")
    if not target.parent.is_dir():
        return []
    return sorted(p for p in target.parent.iterdir() if pattern.match(p.name))


def remove_stale_temporaries(target: Path) -> None:
    """Delete :func:`stale_temporaries` of ``target`` (one job writes a target at a time, so none is live)."""
    for path in stale_temporaries(target):
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)


@contextmanager
def atomic_path(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``target``; rename it over ``target`` on success."""
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(target)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp" + target.suffix, dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        os.replace(tmp_path, target)
    finally:
        tmp_path.unlink(missing_ok=True)


@contextmanager
def atomic_dir(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary folder beside ``target``; it replaces ``target`` on success."""
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(target)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    try:
        yield tmp
        if target.exists():
            shutil.rmtree(target)
        os.replace(tmp, target)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def write_text(target: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` to ``target`` atomically."""
    with atomic_path(target) as tmp:
        tmp.write_text(text, encoding="utf-8")


def _check_finite(value: Any, where: str = "") -> None:
    """Raise ValueError if a JSON-bound value holds NaN or infinity."""
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"refusing to write non-finite number at {where or '<root>'}: {value}")
    if isinstance(value, dict):
        for key, item in value.items():
            _check_finite(item, f"{where}.{key}" if where else str(key))
    elif isinstance(value, (list, tuple)):
        for i, item in enumerate(value):
            _check_finite(item, f"{where}[{i}]")


def write_json(target: str | os.PathLike[str], data: dict[str, Any] | list[Any]) -> None:
    """Write ``data`` as indented JSON atomically; non-finite numbers are refused."""
    _check_finite(data)
    write_text(target, json.dumps(data, indent=2, sort_keys=True, allow_nan=False) + "\n")


def write_with(target: str | os.PathLike[str], writer: Callable[[Path], None]) -> None:
    """Call ``writer(tmp_path)`` and move the result onto ``target`` atomically."""
    with atomic_path(target) as tmp:
        writer(tmp)
