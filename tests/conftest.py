"""Shared fixtures: repository paths, a fresh-clone copy, and image factories."""
from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from clothscope.core.schema import SCHEMA_DIR

ROOT = Path(__file__).resolve().parents[1]
SCHEMAS = SCHEMA_DIR  # the package's schemas, as the workflow reads them
SYNTHETIC = ROOT / "data" / "synthetic"


def decode(path, **limits):
    """``decode_image`` with the config schema's ``prepare`` limits, except those given in ``limits``."""
    from clothscope.core.config import schema_defaults
    from clothscope.core.imageio import decode_image

    prepare = schema_defaults()["prepare"]
    defaults = {"min_px": prepare["min_input_px"], "max_megapixels": prepare["max_megapixels"],
                "clip_threshold": prepare["clip_threshold"]}
    return decode_image(path, **(defaults | limits))


@pytest.fixture(scope="session")
def fresh_clone(tmp_path_factory) -> Path:
    """The files a fresh clone would have (tracked plus untracked, not ignored), copied to a temp dir."""
    target = tmp_path_factory.mktemp("clone")
    files = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"],
        cwd=ROOT, check=True, capture_output=True, text=True,
    ).stdout.split("\0")
    for name in filter(None, files):
        source = ROOT / name
        if source.is_file():
            (target / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target / name)
    return target


def run_snakemake(cwd: Path, *args: str, timeout: int = 600) -> subprocess.CompletedProcess:
    """Run this interpreter's snakemake in ``cwd``."""
    return subprocess.run([sys.executable, "-m", "snakemake", *args], cwd=cwd, capture_output=True, text=True, timeout=timeout)


def job_counts(stdout: str) -> dict[str, int]:
    """Parse snakemake's 'Job stats' table."""
    counts = {}
    for line in stdout.split("Job stats:", 1)[-1].splitlines():
        match = re.match(r"^(\w+)\s+(\d+)$", line.strip())
        if match:
            counts[match.group(1)] = int(match.group(2))
    return counts


def gradient_rgb(height: int = 96, width: int = 128) -> np.ndarray:
    """A smooth 8-bit RGB test pattern."""
    y, x = np.mgrid[0:height, 0:width]
    return np.stack([x * 255 // max(width - 1, 1), y * 255 // max(height - 1, 1), np.full_like(x, 90)], -1).astype(np.uint8)


def woven_rgb(height: int = 96, width: int = 128) -> np.ndarray:
    """:func:`gradient_rgb` with a 3 px checker of +-24 grey levels on it: thread-scale texture that prepare accepts."""
    y, x = np.mgrid[0:height, 0:width]
    checker = np.where((y // 3 + x // 3) % 2 == 0, 24, -24)[..., None]
    return np.clip(gradient_rgb(height, width).astype(int) + checker, 0, 255).astype(np.uint8)


def broken_and_valid_files(folder: Path) -> dict[str, tuple[Path, bool]]:
    """The acceptance folder: broken files (False) and unusual but valid ones (True)."""
    folder.mkdir(parents=True, exist_ok=True)
    rgb = woven_rgb()
    files: dict[str, tuple[Path, bool]] = {}

    def add(name: str, valid: bool) -> Path:
        files[Path(name).stem] = (folder / name, valid)
        return folder / name

    Image.fromarray(rgb).save(add("good.png", True))
    Image.fromarray((rgb.astype(np.uint16) * 257)[..., 0]).save(add("gray16.png", True))
    Image.fromarray(np.dstack([rgb, np.full(rgb.shape[:2], 128, np.uint8)])).save(add("rgba.png", True))
    Image.fromarray(rgb).convert("CMYK").save(add("cmyk.jpg", True), quality=95)
    Image.fromarray(rgb).save(folder / "full.jpg", quality=95)
    data = (folder / "full.jpg").read_bytes()
    add("truncated.jpg", False).write_bytes(data[: len(data) // 3])
    (folder / "full.jpg").unlink()
    add("empty.png", False).write_bytes(b"")
    add("text.png", False).write_text("this is not an image\n")
    Image.new("RGB", (1, 1), (10, 20, 30)).save(add("tiny.png", False))
    Image.new("1", (12000, 9000)).save(add("huge.png", False))
    nan = np.linspace(0, 1, 96 * 128, dtype=np.float32).reshape(96, 128)
    nan[5, 5] = np.nan
    Image.fromarray(nan, mode="F").save(add("nanpixels.tif", False))
    add("directory.png", False).mkdir()
    loop = add("loop.png", False)
    loop.symlink_to(loop)
    add("dangling.png", False).symlink_to(folder / "gone.png")
    add("missing.png", False)
    return files


#: what the rejection of each file-level problem of :func:`broken_and_valid_files` says
FILE_PROBLEMS = {"nanpixels": "1 pixel(s) hold NaN or infinite values", "directory": "is a directory", "loop": "symlink loop", "dangling": "broken symlink", "missing": "does not exist",
                 "empty": "empty (0 bytes)"}


NON_FINITE_TOKENS = {"nan", "inf", "-inf", "+inf", "infinity", "-infinity"}


def non_finite_outputs(folder: Path) -> list[str]:
    """Every JSON, CSV/TSV and Parquet file under ``folder`` that holds a NaN or infinite number, with where."""
    import json

    import pyarrow as pa
    import pyarrow.compute as pc
    import pyarrow.parquet as pq

    found = []

    def refuse(token: str) -> None:
        raise ValueError(token)

    for path in sorted(folder.rglob("*")):
        if path.suffix == ".json":
            try:
                json.loads(path.read_text(), parse_constant=refuse)
            except ValueError as err:
                found.append(f"{path}: {err}")
        elif path.suffix in (".csv", ".tsv"):
            separator = "\t" if path.suffix == ".tsv" else ","
            for number, line in enumerate(path.read_text().splitlines(), start=1):
                if any(cell.strip().lower() in NON_FINITE_TOKENS for cell in line.split(separator)):
                    found.append(f"{path} line {number}")
        elif path.suffix == ".parquet":
            table = pq.read_table(path)
            for name, column in zip(table.column_names, table.columns):
                if pa.types.is_floating(column.type) and pc.all(pc.is_finite(column), skip_nulls=True).as_py() is False:
                    found.append(f"{path}: column {name}")
    return found
