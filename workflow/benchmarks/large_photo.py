"""Benchmark: time and peak memory of ``prepare`` on large phone photos (12 to 100 megapixels).

Writes a JPEG of each size (a woven-looking texture with noise, quality 90) and prepares it
in a fresh Python process with the configured ``prepare`` settings (thread scale included),
reading that process's peak resident memory from ``resource.getrusage``.

    .venv/bin/python workflow/benchmarks/large_photo.py [--sizes 4000x3000,8000x6000,10000x10000]

Writes ``results/bench/large_photo.{csv,md}``.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from harness import ROOT, publish, validated_config
from PIL import Image

#: runs in the child process: prepare one photo, print seconds and peak RSS (KiB on Linux)
CHILD = """
import json, resource, sys, time
from clothscope.prepare.image import PrepareSettings, prepare_image
from clothscope.features.structure import StructureSettings
photo, out, prepare, structure = sys.argv[1], sys.argv[2], json.loads(sys.argv[3]), json.loads(sys.argv[4])
started = time.perf_counter()
record = prepare_image("large", photo, out, PrepareSettings(**prepare), StructureSettings(**structure))
seconds = time.perf_counter() - started
print(json.dumps({"status": record["status"], "reason": record["reason"], "seconds": seconds,
                  "crop_px": (record.get("scale") or {}).get("crop_px"),
                  "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def woven_jpeg(width: int, height: int, target: Path) -> None:
    """A plain-weave-like texture (period 24 px) with noise, saved as JPEG quality 90, built in row bands."""
    rng = np.random.default_rng(0)
    x = np.arange(width)
    with Image.new("RGB", (width, height)) as image:
        for top in range(0, height, 1000):
            y = np.arange(top, min(top + 1000, height))[:, None]
            weave = 0.5 + 0.25 * np.sin(2 * np.pi * x / 24) * np.sin(2 * np.pi * y / 24)
            band = np.clip(weave + rng.normal(0, 0.05, weave.shape), 0, 1)
            rgb = (np.stack([band * 0.8, band * 0.6, band * 0.4], axis=-1) * 255).astype(np.uint8)
            image.paste(Image.fromarray(rgb), (0, top))
        image.save(target, quality=90)


def measure(photo: Path, out: Path, config: dict) -> dict:
    """Prepare ``photo`` in a child process; its status, seconds and peak memory."""
    result = subprocess.run([sys.executable, "-c", CHILD, str(photo), str(out), json.dumps(config["prepare"]),
                             json.dumps(config["features"]["structure"])], capture_output=True, text=True, check=True)
    return json.loads(result.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="4000x3000,8000x6000,10000x10000")
    args = parser.parse_args()
    config = validated_config()
    rows = []
    with tempfile.TemporaryDirectory() as work:
        for size in args.sizes.split(","):
            width, height = map(int, size.split("x"))
            photo = Path(work) / f"{size}.jpg"
            woven_jpeg(width, height, photo)
            row = measure(photo, Path(work) / f"prepared_{size}", config)
            rows.append({"size": size, "megapixels": width * height / 1e6, "file_mb": photo.stat().st_size / 1e6, **row})
            photo.unlink()
    frame = pd.DataFrame(rows)
    lines = ["# prepare on large photos (JPEG, quality 90)", "",
             "One fresh process per photo; peak resident memory of that process (Python and imports included).", "",
             "| size | megapixels | file | status | crop | seconds | peak memory |", "|---|---|---|---|---|---|---|"]
    lines += [f"| {r.size} | {r.megapixels:.0f} | {r.file_mb:.1f} MB | {r.status} | {r.crop_px or '-'} | {r.seconds:.1f} | "
              f"{r.peak_rss_mb:.0f} MB |" for r in frame.itertuples()]
    publish(ROOT / "results" / "bench", "large_photo", frame, "\n".join(lines) + "\n", float_format="%.3f")


if __name__ == "__main__":
    main()
