"""Benchmark: time and peak memory of ``prepare`` on large phone photos (12 to 100 megapixels).

Writes a photo of each size and format (a woven-looking texture with noise: JPEG quality 90,
16-bit PNG or OpenEXR) and prepares it in a fresh Python process with the configured
``prepare`` settings (thread scale included), reading that process's own peak resident memory (``VmHWM``). The ``prepare`` rule's memory request
(:func:`clothscope.prepare.image.prepare_memory_mb`) is set beside each measurement.

    .venv/bin/python workflow/benchmarks/large_photo.py [--sizes 4000x3000,8000x6000,10000x10000] [--formats jpg,png16,exr]

Writes ``results/bench/large_photo.{csv,md}``.
"""
from __future__ import annotations

import argparse
import itertools
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from harness import ROOT, publish, validated_config
from PIL import Image

from clothscope.prepare.image import prepare_memory_mb

#: runs in the child process: prepare one photo, print seconds and peak RSS. The peak is the process's own
#: ``VmHWM``: ``getrusage``'s ``ru_maxrss`` survives ``execve`` and so holds the parent's peak when the child
#: was started by ``vfork`` (as ``subprocess`` does), which made a child that decoded 12 MP read 6.4 GB.
CHILD = """
import json, resource, sys, time
def peak_rss_mb():
    try:
        with open("/proc/self/status") as status:
            return next(int(line.split()[1]) for line in status if line.startswith("VmHWM:")) / 1024
    except (OSError, StopIteration):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
from clothscope.prepare.image import PrepareSettings, prepare_image
from clothscope.features.structure import StructureSettings
photo, out, prepare, structure = sys.argv[1], sys.argv[2], json.loads(sys.argv[3]), json.loads(sys.argv[4])
started = time.perf_counter()
record = prepare_image("large", photo, out, PrepareSettings(**prepare), StructureSettings(**structure))
seconds = time.perf_counter() - started
print(json.dumps({"status": record["status"], "reason": record["reason"], "seconds": seconds,
                  "crop_px": (record.get("scale") or {}).get("crop_px"),
                  "peak_rss_mb": peak_rss_mb()}))
"""


def woven_band(x: np.ndarray, y: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Rows ``y`` of a plain-weave-like texture (period 24 px) with noise, RGB in [0, 1]."""
    weave = 0.5 + 0.25 * np.sin(2 * np.pi * x / 24) * np.sin(2 * np.pi * y / 24)
    band = np.clip(weave + rng.normal(0, 0.05, weave.shape), 0, 1)
    return np.stack([band * 0.8, band * 0.6, band * 0.4], axis=-1)


def woven_jpeg(width: int, height: int, target: Path) -> None:
    """The woven texture saved as JPEG quality 90, built in row bands."""
    rng = np.random.default_rng(0)
    x = np.arange(width)
    with Image.new("RGB", (width, height)) as image:
        for top in range(0, height, 1000):
            rgb = woven_band(x, np.arange(top, min(top + 1000, height))[:, None], rng)
            image.paste(Image.fromarray((rgb * 255).astype(np.uint8)), (0, top))
        image.save(target, quality=90)


def woven_bitmap(width: int, height: int, target: Path) -> None:
    """The woven texture as a 16-bit PNG or an OpenEXR (by ``target``'s suffix), written by Mitsuba's Bitmap."""
    import mitsuba as mi  # a second of import, only for these two formats

    mi.set_variant("scalar_rgb")
    rgb = woven_band(np.arange(width), np.arange(height)[:, None], np.random.default_rng(0)).astype(np.float32)
    if target.suffix == ".png":
        bitmap = mi.Bitmap(np.round(rgb * 65535).astype(np.uint16), mi.Bitmap.PixelFormat.RGB)
    else:
        bitmap = mi.Bitmap(rgb, mi.Bitmap.PixelFormat.RGB)
    del rgb
    bitmap.write(str(target))


#: suffix of the file each format is written as
SUFFIXES = {"jpg": ".jpg", "png16": ".png", "exr": ".exr"}


def measure(photo: Path, out: Path, config: dict) -> dict:
    """Prepare ``photo`` in a child process; its status, seconds and peak memory."""
    result = subprocess.run([sys.executable, "-c", CHILD, str(photo), str(out), json.dumps(config["prepare"]),
                             json.dumps(config["features"]["structure"])], capture_output=True, text=True, check=True)
    return json.loads(result.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="4000x3000,8000x6000,10000x10000")
    parser.add_argument("--formats", default="jpg", help=f"any of {', '.join(SUFFIXES)}")
    args = parser.parse_args()
    config = validated_config()
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for fmt, size in itertools.product(args.formats.split(","), args.sizes.split(",")):
            width, height = map(int, size.split("x"))
            photo = Path(work) / f"{size}{SUFFIXES[fmt]}"
            (woven_jpeg if fmt == "jpg" else woven_bitmap)(width, height, photo)
            row = measure(photo, Path(work) / f"prepared_{fmt}_{size}", config)
            rows.append({"format": fmt, "size": size, "megapixels": width * height / 1e6, "file_mb": photo.stat().st_size / 1e6,
                         **row, "requested_mb": prepare_memory_mb(photo)})
            photo.unlink()
    frame = pd.DataFrame(rows)
    lines = ["# prepare on large photos", "",
             "One fresh process per photo; peak resident memory of that process (Python and imports included); "
             "`requested` is the `prepare` rule's `mem_mb` for that photo (`clothscope.prepare.image.prepare_memory_mb`).", "",
             "| format | size | megapixels | file | status | crop | seconds | peak memory | requested |",
             "|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r.format} | {r.size} | {r.megapixels:.0f} | {r.file_mb:.1f} MB | {r.status} | {r.crop_px or '-'} | "
              f"{r.seconds:.1f} | {r.peak_rss_mb:.0f} MB | {r.requested_mb} MB |" for r in frame.itertuples()]
    publish(ROOT / "results" / "bench", "large_photo", frame, "\n".join(lines) + "\n", float_format="%.3f")


if __name__ == "__main__":
    main()
