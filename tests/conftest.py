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

ROOT = Path(__file__).resolve().parents[1]
SCHEMAS = ROOT / "workflow" / "schemas"
SYNTHETIC = ROOT / "data" / "synthetic"


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


def broken_and_valid_files(folder: Path) -> dict[str, tuple[Path, bool]]:
    """The acceptance folder: broken files (False) and unusual but valid ones (True)."""
    folder.mkdir(parents=True, exist_ok=True)
    rgb = gradient_rgb()
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
    add("directory.png", False).mkdir()
    loop = add("loop.png", False)
    loop.symlink_to(loop)
    add("dangling.png", False).symlink_to(folder / "gone.png")
    add("missing.png", False)
    return files


#: what the rejection of each file-level problem of :func:`broken_and_valid_files` says
FILE_PROBLEMS = {"directory": "is a directory", "loop": "symlink loop", "dangling": "broken symlink", "missing": "does not exist",
                 "empty": "empty (0 bytes)"}
