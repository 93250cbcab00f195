"""Benchmark: how far the fitted light's azimuth is from the true one, and what the threads read, per capture.

    .venv/bin/python workflow/benchmarks/light_direction.py [--set RUN SHEET ...] [--name light_direction]

For every image of each run whose sample sheet has ground truth (the embedded sets and the field
sets), this compares the true light's azimuth with (a) the light the fit ended with (the normal-map
stage's ``state.json``), (b) the light the falloff's grid search starts from
(:func:`clothscope.fit.light.estimate_light`) and (c) the side the threads are lit from
(:func:`clothscope.fit.light.thread_light`, with its strength), all on the prepared photo. Only
lights off the lens have an azimuth to find: the flash, ring and coaxial captures are shown for
the threads' strength alone. Default: the embedded design set and the two design weave sets.
Writes ``results/bench/<name>.{csv,md}``. Nothing is chosen here.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd
from harness import ROOT, publish, shown

from clothscope.core.truth import truth_paths
from clothscope.fit.light import estimate_light, thread_light
from clothscope.fit.model import FitCamera
from clothscope.fit.outputs import STATE_FILE
from clothscope.fit.target import SkipStage, load_prepared

#: captures whose light sits at the lens (no azimuth to find)
AT_THE_LENS = ("phone_flash", "macro_ring", "macro_coaxial")
DEFAULT_SETS = (("results", "config/samples.tsv"),
                ("results/weaves/run", "results/weaves/field/samples.tsv"),
                ("results/weaves_confirm/run", "results/weaves_confirm/field/samples.tsv"))


def azimuth_error(a: float, b: float) -> float:
    """Absolute difference of two azimuths, degrees in [0, 180]."""
    return float(abs((a - b + 180.0) % 360.0 - 180.0))


def true_light(image_path: Path) -> tuple[str, float, float]:
    """The capture (``embedded`` for the embedded sets), polar and azimuth of an image's true light."""
    record = json.loads(truth_paths(image_path)["json"].read_text(encoding="utf-8"))
    if "draw" in record:
        draw = record["draw"]
        return str(draw["capture"]), float(draw["light_polar_deg"]), float(draw["light_azimuth_deg"])
    return "embedded", float(record["light"]["polar_deg"]), float(record["light"]["azimuth_deg"])


def image_rows(run: Path, sheet: Path) -> list[dict]:
    """One row per fitted image of ``run``: the true light and the three readings of its azimuth."""
    rows = []
    for sample in pd.read_csv(sheet, sep="\t", dtype=str).itertuples():
        path = Path(sample.path) if Path(sample.path).is_absolute() else ROOT / sample.path
        state_path = run / "fit" / sample.image_id / "normals" / STATE_FILE
        if not truth_paths(path)["json"].is_file() or not state_path.is_file():
            continue
        state = json.loads(state_path.read_text(encoding="utf-8"))
        if state.get("status") != "fitted":
            continue
        try:
            photo = load_prepared(run / "prepared" / sample.image_id)
        except SkipStage:
            continue
        capture, polar, azimuth = true_light(path)
        falloff, _ = estimate_light(photo.image, photo.weight, FitCamera())
        threads, strength = thread_light(photo.image, photo.weight)
        fitted = state["scene"]["light"]
        rows.append({"run": shown(run), "image_id": sample.image_id, "capture": capture, "true_polar_deg": polar,
                     "fitted_polar_deg": float(fitted["polar_deg"]), "falloff_polar_deg": falloff.polar_deg,
                     "fitted_error_deg": azimuth_error(float(fitted["azimuth_deg"]), azimuth),
                     "falloff_error_deg": azimuth_error(falloff.azimuth_deg, azimuth),
                     "threads_error_deg": azimuth_error(threads, azimuth), "threads_strength": strength})
    return rows


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per capture: images, median azimuth errors, how many within 30 degrees, median polar angles, strengths."""
    def within(column: str) -> tuple[str, object]:
        return column, lambda errors: int((errors <= 30.0).sum())

    grouped = table.groupby("capture").agg(
        images=("image_id", "size"), true_polar=("true_polar_deg", "median"), fitted_polar=("fitted_polar_deg", "median"),
        fitted_error=("fitted_error_deg", "median"), fitted_within_30=within("fitted_error_deg"),
        falloff_error=("falloff_error_deg", "median"), falloff_within_30=within("falloff_error_deg"),
        threads_error=("threads_error_deg", "median"), threads_within_30=within("threads_error_deg"),
        strength_median=("threads_strength", "median"), strength_90th=("threads_strength", lambda s: float(np.quantile(s, 0.9))))
    grouped = grouped.round(2).astype(object)
    grouped.loc[grouped.index.isin(AT_THE_LENS), [column for column in grouped.columns if "error" in column
                                                 or "within" in column or column == "true_polar"]] = "-"
    return grouped.reset_index()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", nargs=2, action="append", metavar=("RUN", "SHEET"), dest="sets",
                        help="a run folder and the sample sheet it was run on (repeat; default: the embedded design set and two weave sets)")
    parser.add_argument("--name", default="light_direction", help="report name under results/bench/")
    args = parser.parse_args()
    runs = [(ROOT / run, ROOT / sheet) for run, sheet in (args.sets or DEFAULT_SETS)]
    table = pd.DataFrame([row for run, sheet in runs for row in image_rows(run, sheet)])
    if table.empty:
        raise SystemExit("light_direction: error: no fitted image with ground truth in those runs")
    text = ("# The light's azimuth: the fit, the falloff's grid search and the threads\n\n"
            "Runs: " + ", ".join(f"`{shown(run)}`" for run, _ in runs) + ". Per capture: median true and fitted polar angles; "
            "median azimuth error (degrees) and images within 30 degrees of the fitted light, of the falloff's start and of "
            "the threads' reading; the threads' strength (median, 90th percentile). `-`: the light is at the lens.\n\n"
            + summary(table).to_markdown(index=False, floatfmt=".2f") + "\n")
    publish(ROOT / "results" / "bench", args.name, table, text, float_format="%.3f")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
