"""Benchmark: the classifier of record without and with the photo's whole frame (``photo_frame``) among its members.

    .venv/bin/python workflow/benchmarks/frame_candidate.py RUN [RUN ...] [--with-only] [--name frame_candidate]

For each run folder, the photo each image's ``prepare`` read (``prepared/<id>/status.json``'s ``path``) is decoded
again and described by :func:`frame_columns`: its whole centred square, box-resampled to 256 px, whose luminance gives
uniform LBP histograms (:data:`clothscope.features.structure.LBP_SCALES`) and the log power in 10 rings of its spectrum
between 2 and 100 cycles per frame, their mean removed (``docs/design.md``, "The photo's whole frame as a member of the
vote"). The descriptor is invariant to rotation, colour and exposure, not to scale. It was measured under two rules and
not adopted, so it lives here, not in the package.

The frame columns join the run's photo rows (and, as the image's own values, its tile rows), and the classifier of
record as configured (its vote, pruned at ``classify.prune``, test tiles) is scored by LOOCV without and with
``photo_frame`` among its candidates. ``--with-only`` skips the "without" LOOCV and reads it from the run's own record
(``reports/fitted/accuracy.json``), which the same LOOCV made when the run's tables are of the current version.
Writes ``results/bench/<name>.{csv,md}``.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from class_subsets import classify_config
from field_set import DECODE
from harness import ROOT, record_inputs, record_loocv, run_tables, runs_report, shown
from PIL import Image

from clothscope.core.fourier import radius_grid
from clothscope.core.imageio import decode_image, luminance
from clothscope.features.structure import LBP_COLUMNS, lbp_baseline
from clothscope.prepare.image import read_status

#: side (pixels) of the resampled frame
FRAME_SIZE = 256
#: edges of the spectrum's rings, in cycles per frame (log spaced)
FRAME_RING_EDGES = tuple(float(r) for r in np.geomspace(2.0, 100.0, 11))
#: the frame's LBP histogram columns: the ``lbp_*`` baseline's, prefixed
FRAME_LBP_COLUMNS = tuple(f"f_{name}" for name in LBP_COLUMNS)
#: the frame's ring columns: log power, mean removed
FRAME_RING_COLUMNS = tuple(f"f_ring_{k}" for k in range(len(FRAME_RING_EDGES) - 1))
#: every frame column, in table order
FRAME_COLUMNS = FRAME_LBP_COLUMNS + FRAME_RING_COLUMNS
#: power floor before the log
POWER_FLOOR = 1e-20
#: a frame whose contrast spans less than this is flat: its rings are all zero
FLAT_CONTRAST = 1e-6


def frame_field(rgb: np.ndarray) -> np.ndarray:
    """(FRAME_SIZE, FRAME_SIZE) luminance of the centred square of a decoded (H, W, >=3) photo, box-resampled."""
    image = np.asarray(rgb)
    if image.ndim != 3 or image.shape[-1] < 3:
        raise ValueError(f"the frame needs an (H, W, 3) photo, got shape {image.shape}")
    height, width = image.shape[:2]
    side = min(height, width)
    top, left = (height - side) // 2, (width - side) // 2
    square = luminance(image[top:top + side, left:left + side, :3]).astype(np.float32)
    resized = Image.fromarray(square).resize((FRAME_SIZE, FRAME_SIZE), Image.Resampling.BOX)
    return np.asarray(resized, dtype=np.float64)


def ring_powers(field: np.ndarray) -> np.ndarray:
    """Log mean power of the (Hann-windowed) field over its mean in each ring of :data:`FRAME_RING_EDGES`, mean removed."""
    size = field.shape[0]
    contrast = field / max(float(field.mean()), 1e-9) - 1.0
    if np.ptp(contrast) < FLAT_CONTRAST:  # rounding, not texture
        return np.zeros(len(FRAME_RING_EDGES) - 1)
    hann = np.hanning(size)
    power = np.abs(np.fft.fftshift(np.fft.fft2(contrast * np.outer(hann, hann)))) ** 2
    radius = radius_grid(size)[2]
    edges = FRAME_RING_EDGES
    rings = np.array([power[(radius >= a) & (radius < b)].mean() for a, b in zip(edges[:-1], edges[1:])])
    logs = np.log(np.maximum(rings, POWER_FLOOR))
    return logs - logs.mean()


def frame_columns(rgb: np.ndarray) -> dict[str, float]:
    """The :data:`FRAME_COLUMNS` of a decoded photo (:func:`frame_field`); every value finite.

    Raises
    ------
    ValueError
        If the photo is not (H, W, 3) or holds NaN or infinite values.
    """
    field = frame_field(rgb)
    if not np.all(np.isfinite(field)):
        raise ValueError("the photo's frame holds NaN or infinite values")
    histograms = {f"f_{name}": value for name, value in lbp_baseline(field).items()}
    return histograms | {name: float(v) for name, v in zip(FRAME_RING_COLUMNS, ring_powers(field), strict=True)}


#: the member's name among the record's candidates
MEMBER = "photo_frame"


def photo_path(run: Path, image_id: str) -> Path:
    """The photo ``prepare`` read for an image of ``run`` (relative paths are under the repository root)."""
    path = Path(read_status(run / "prepared" / image_id)["path"])
    return path if path.is_absolute() else ROOT / path


def frame_table(run: Path, image_ids: list[str]) -> pd.DataFrame:
    """The photo's frame columns (as ``photo.<column>``) of each image, indexed by image id."""
    rows = {i: frame_columns(decode_image(photo_path(run, i), *DECODE).rgb) for i in image_ids}
    table = pd.DataFrame.from_dict(rows, orient="index")
    return table.rename(columns=lambda c: f"photo.{c}")


def own_record(run: Path) -> int:
    """Images right by the run's own classifier of record."""
    return int(json.loads((run / "reports" / "fitted" / "accuracy.json").read_text(encoding="utf-8"))["correct"])


def run_rows(run: Path, with_only: bool = False) -> list[dict]:
    """Images right by the record without and with ``photo_frame``, and how many folds kept the member."""
    ok, tiles, candidates = record_inputs(*run_tables(run), "auto")
    frame = frame_table(run, list(ok["image_id"].astype(str)))
    ok = ok.join(frame, on="image_id")
    tiles = tiles.join(frame, on="image_id") if tiles is not None else None
    settings = classify_config()
    listed = {**candidates, MEMBER: list(frame.columns)}
    with_frame = record_loocv(ok, listed, tiles, settings)
    without = own_record(run) if with_only else record_loocv(ok, candidates, tiles, settings).correct
    return [{"run": shown(run), "images": with_frame.n, "without": without, "with": with_frame.correct,
             "without_from": "the run's record" if with_only else "this LOOCV",
             "folds_kept": with_frame.selected.get(MEMBER, 0)}]


def markdown(table: pd.DataFrame) -> str:
    """Per run, images right without and with the member; then summed."""
    lines = ["LOOCV of the classifier of record as configured, without and with `photo_frame` among its members. "
             "Images right.", "",
             "| run | images | without | with | change | folds kept it | without from |", "|---|---|---|---|---|---|---|"]
    for _, r in table.iterrows():
        lines.append(f"| `{r['run']}` | {r['images']} | {r['without']} | {r['with']} | {r['with'] - r['without']:+d} | "
                     f"{r['folds_kept']} | {r['without_from']} |")
    total = table[["images", "without", "with"]].sum()
    lines.append(f"| all | {total['images']} | {total['without']} | {total['with']} | "
                 f"{total['with'] - total['without']:+d} | | |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    runs_report(__doc__, "frame_candidate", "run folders with fitted and photo feature tables", run_rows, markdown,
                flags=(("--with-only", "read the 'without' figure from the run's own record"),))
