"""Benchmark: the fitted relief against the photo alone, image by image, in several runs and pooled over them.

    .venv/bin/python workflow/benchmarks/fit_vs_photo.py RUN [RUN ...] [--name fit_vs_photo]

In each run folder the feature-set report's ``vote_fitted`` and ``vote_photo`` are scored by LOOCV as the report
scores them (the run's tiles; test tiles as configured). The two average the same five QDAs, on the fitted relief or
on the photo's luminance, so their pairing is fixed before any score, unlike the report's "best photo-only set",
which is the best of several on the images scored. The classifier of record's LOOCV predictions (``record``) are read
from the run's ``reports/fitted/predictions.csv``, and the same classifier is scored on the photo's table alone
(``record_photo``: what the workflow does with ``features.normal_source: photo``, which runs no fit). Per run, summed
over the runs, by the thread period ``prepare`` read at the working resolution (``reports/prepared.tsv``) and by
class: images right, and for each pair the images only one side got right with the exact McNemar p of that split
(the runs' images taken as independent). Writes ``results/bench/<name>.csv`` (one row per image) and ``.md``.
Nothing is chosen here.
"""
from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
from harness import record_options, run_tables, runs_report, shown, validated_config

from clothscope.classify.feature_sets import FEATURE_SETS, common_images, discordant, mcnemar_p, score_feature_set
from clothscope.classify.job import photo_only_loocv
from clothscope.prepare.rejections import FAR_BELOW_PX

#: The pairs compared, each ``(side, reference)``: names of per-image hit columns.
PAIRS = (("vote_fitted", "vote_photo"), ("record", "vote_photo"), ("record", "record_photo"))


def scale_bands() -> dict[str, tuple[float, float]]:
    """Working thread periods (px, ``[low, high)``) the images are grouped by: far under the configured band
    (:data:`~clothscope.prepare.rejections.FAR_BELOW_PX`), under it, in it (``prepare.period_band``), above it."""
    low, high = validated_config()["prepare"]["period_band"]
    return {f"under {FAR_BELOW_PX:g} px": (0.0, FAR_BELOW_PX), f"{FAR_BELOW_PX:g}-{low:g} px": (FAR_BELOW_PX, low),
            f"{low:g}-{high:g} px": (low, high), f"{high:g} px and over": (high, math.inf)}


def record_hits(run: Path) -> pd.DataFrame:
    """The images of the run's classifier of record's LOOCV (by image id): ``fabric_class``, and ``record``, whether
    it got the image right."""
    path = run / "reports" / "fitted" / "predictions.csv"
    if not path.is_file():
        raise SystemExit(f"{shown(path)}: no such file; run the workflow into {shown(run)} first")
    predictions = pd.read_csv(path, dtype={"image_id": str})
    predictions = predictions[predictions["split"] == "loocv"].set_index("image_id")
    return pd.DataFrame({"fabric_class": predictions["true_class"],
                         "record": predictions["predicted_class"] == predictions["true_class"]})


def working_periods(run: Path) -> pd.Series:
    """Each image's thread period at the working resolution (``reports/prepared.tsv``; NaN where none was read)."""
    path = run / "reports" / "prepared.tsv"
    if not path.is_file():
        raise SystemExit(f"{shown(path)}: no such file; run the workflow into {shown(run)} first")
    table = pd.read_csv(path, sep="\t", dtype={"image_id": str})
    if "working_period_px" not in table.columns:
        raise SystemExit(f"{shown(path)}: no working_period_px column; rerun its rule (--forcerun rejection_report)")
    return pd.to_numeric(table.set_index("image_id")["working_period_px"], errors="coerce")


def scale_band(period: float, bands: dict[str, tuple[float, float]]) -> str:
    """The one of ``bands`` (:func:`scale_bands`) a working period falls in (``no lattice`` for NaN)."""
    if not math.isfinite(period):
        return "no lattice"
    return next(name for name, (low, high) in bands.items() if low <= period < high)


def photo_record_hits(tables: dict[str, pd.DataFrame], tiles: dict[str, pd.DataFrame], settings: dict) -> pd.Series:
    """Which images the classifier of record as configured, trained on the photo's table alone (the workflow with
    ``features.normal_source: photo``, no fit), gets right in its LOOCV (boolean, by image id)."""
    return photo_only_loocv(tables["photo"], tiles.get("photo"), settings["feature_set"], settings["reg"],
                            settings["subspace"], **record_options(settings)).right_by_image()


def run_rows(run: Path) -> list[dict]:
    """One row per image of a run: whether each side got it right, and its working thread period and band."""
    settings = validated_config()["classify"]
    tables, tiles = run_tables(run)
    images = common_images(tables)
    by_name = {s.name: s for s in FEATURE_SETS}
    hits = {}
    for name in ("vote_fitted", "vote_photo"):
        row, right = score_feature_set(by_name[name], tables, images, settings["reg"], settings["subspace"], tiles,
                                       test_tiles=settings["test_tiles"] == "mean")
        if right is None:
            raise SystemExit(f"{shown(run)}: {name} could not be scored: {row['reason']}")
        hits[name] = right
    hits["record_photo"] = photo_record_hits(tables, tiles, settings)
    record = record_hits(run)
    frame = pd.DataFrame(hits).join(record["record"], how="inner").dropna().astype(bool)
    periods, bands = working_periods(run).reindex(frame.index), scale_bands()
    return [{"run": shown(run), "image_id": image, "fabric_class": record.at[image, "fabric_class"],
             "working_period_px": float(periods[image]), "scale_band": scale_band(float(periods[image]), bands),
             **frame.loc[image].to_dict()} for image in frame.index]


def pair_cell(hits: pd.DataFrame, side: str, reference: str) -> str:
    """``+a / -b, p = ...``: images only ``side`` got right (a), only ``reference`` (b), exact McNemar p."""
    only_side, only_reference = discordant(hits[side], hits[reference])
    return f"+{only_side} / -{only_reference}, p = {mcnemar_p(only_side, only_reference):.2g}"


def count_lines(groups: list[tuple[str, pd.DataFrame]], heading: str) -> list[str]:
    """A Markdown table: per group, images, images right of each side, and each pair's split."""
    sides = ("vote_fitted", "vote_photo", "record", "record_photo")
    lines = [f"| {heading} | images | {' | '.join(sides)} | {' | '.join(f'{a} against {b}' for a, b in PAIRS)} |",
             "|---" * (2 + len(sides) + len(PAIRS)) + "|"]
    for name, hits in groups:
        counts = " | ".join(str(int(hits[side].sum())) for side in sides)
        lines.append(f"| {name} | {len(hits)} | {counts} | {' | '.join(pair_cell(hits, *pair) for pair in PAIRS)} |")
    return lines


def markdown(table: pd.DataFrame) -> str:
    """Per run, summed over the runs, and by thread-scale band over the runs."""
    runs = [(f"`{run}`", hits) for run, hits in table.groupby("run", sort=False)]
    bands = [(band, table[table["scale_band"] == band]) for band in (*scale_bands(), "no lattice")
             if (table["scale_band"] == band).any()]
    lines = ["# The fitted relief against the photo alone, image by image", "",
             "LOOCV images right of `vote_fitted` (the five QDAs on the fitted relief), `vote_photo` (the same on the "
             "photo's luminance), the classifier of record (`record`, fitted relief and photo) and the same classifier "
             "on the photo alone (`record_photo`: `features.normal_source: photo`, no fit). A pair's cell is +a / -b: "
             "the images only the first of the pair got right, and only the second; p is the exact McNemar test of "
             "that split.", "",
             *count_lines([*runs, ("summed over the runs", table)], "run"), "",
             "By the thread period `prepare` read at the working resolution (`reports/prepared.tsv`), over the runs:", "",
             *count_lines(bands, "working thread period"), "", "By class, over the runs:", "",
             *count_lines(list(table.groupby("fabric_class")), "class")]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    runs_report(__doc__, "fit_vs_photo", "run folders (each with features/{fitted,photo} and reports/fitted)",
                run_rows, markdown)
