"""Benchmark: does the relief repeat where the photo repeats? The true and the fitted relief, at the photo's repeat.

    .venv/bin/python workflow/benchmarks/repeat_correlation.py RUN:SHEET [RUN:SHEET ...] [--name repeat_correlation]

For every accepted image of each run, the translations under which the prepared photo's shading repeats
(:func:`clothscope.fit.repeat.photo_repeats`) are taken, and at each of them the normalised autocorrelation of the
photo's shading, of the true height map put in the prepared frame (where the sheet's image has ground truth) and of
the fitted height map (``fit/<id>/normals/height.exr``), each with shading wider than
:data:`clothscope.fit.repeat.HIGHPASS_PX` removed, is read. Writes one row per image and translation, and the
medians per run and class, into ``results/bench/<name>.{csv,md}``. Nothing is chosen here.
"""
from __future__ import annotations

import argparse
import numpy as np
import pandas as pd
from harness import ROOT, publish
from scipy import ndimage

from clothscope.core.imageio import read_exr
from clothscope.features.sources import load_truth
from clothscope.fit.repeat import HIGHPASS_PX, autocorrelation, photo_repeats
from clothscope.fit.target import SkipStage, load_prepared


def correlation_at(field: np.ndarray, shift: tuple[float, float]) -> float:
    """Normalised autocorrelation of ``field`` (broad shading removed) at ``shift`` (rows, cols, its own pixels)."""
    values = np.asarray(field, dtype=np.float64)
    values = values - ndimage.gaussian_filter(values, HIGHPASS_PX, mode="reflect")
    corr = autocorrelation(values)
    centre = np.array(corr.shape) // 2
    return float(ndimage.map_coordinates(corr, [[centre[0] + shift[0]], [centre[1] + shift[1]]], order=1)[0])


def image_rows(run: str, image_id: str, image_path: str, fabric_class: str) -> list[dict]:
    """One row per photo translation of one image (``run``: its results folder, from the repository root)."""
    prepared = ROOT / run / "prepared" / image_id
    try:
        photo = load_prepared(prepared).image
    except SkipStage:
        return []
    height_file = ROOT / run / "fit" / image_id / "normals" / "height.exr"
    fitted = read_exr(height_file)[..., 0] if height_file.is_file() else None
    truth = load_truth(image_path, prepared)
    rows = []
    for repeat in photo_repeats(photo):
        row = {"run": run, "image_id": image_id, "fabric_class": fabric_class,
               "shift_px": float(np.hypot(*repeat.shift_px)), "photo": repeat.correlation}
        for name, field in (("truth", truth.field), ("fitted", fitted)):
            if field is not None:
                scale = field.shape[0] / (photo.shape[0] * (1.06 if name == "fitted" else 1.0))  # the map overhangs by its margin
                row[name] = correlation_at(field, (repeat.shift_px[0] * scale, repeat.shift_px[1] * scale))
        rows.append(row)
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", help="RUN:SHEET (a results folder and its sample sheet)")
    parser.add_argument("--name", default="repeat_correlation")
    args = parser.parse_args()
    rows = []
    for pair in args.runs:
        run, sheet = pair.split(":")
        for sample in pd.read_csv(ROOT / sheet, sep="\t").itertuples():
            rows += image_rows(run, sample.image_id, str(ROOT / sample.path), sample.fabric_class)
    table = pd.DataFrame(rows)
    columns = [c for c in ("photo", "truth", "fitted") if c in table]
    medians = table.groupby(["run", "fabric_class"])[columns].median().round(3)
    overall = table.groupby("run")[columns].median().round(3)
    text = "\n".join([
        "# Does the relief repeat where the photo repeats?", "",
        "Normalised autocorrelation at the translations under which each prepared photo's shading repeats "
        "(`clothscope.fit.repeat.photo_repeats`, one or two per photo): of the photo's shading, of the true height map "
        "in the prepared frame and of the fitted height map. 1 is a perfect repeat, 0 none.", "",
        f"{table.groupby('run')['image_id'].nunique().sum()} images with a repeat over the runs, {len(table)} translations. Medians per run:", "",
        overall.to_markdown(), "", "Per class:", "", medians.to_markdown(), ""])
    publish(ROOT / "results" / "bench", args.name, table, text, float_format="%.4f")


if __name__ == "__main__":
    main()
