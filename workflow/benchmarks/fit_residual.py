"""Benchmark: the share of the photo the fit leaves unexplained, as a fitted column beside the BRDF.

    .venv/bin/python workflow/benchmarks/fit_residual.py RUN [RUN ...] [--name fit_residual] [--fitted-of-others SEED]

For each run folder, every fitted image gets the column ``unexplained``: the log of its normal-map stage's
residual energy over the photo's own variance (:func:`clothscope.fit.target.unexplained_share`), read from
``compare.png`` (the photo and the fit's preview, 8-bit sRGB, turned back to linear) where the run's fits did not
record it. The feature-set report's fitted sets and the classifier of
record (as the ``classify`` rule runs them) are scored on the run's tables with the column in the BRDF columns and
without it. ``--fitted-of-others SEED`` first gives each image another image's fitted features (and its column),
the failure the record's pruning guards against. Writes ``results/bench/<name>.{csv,md}``. Nothing is chosen here
(``docs/design.md``, "What the fit cannot explain").
"""
from __future__ import annotations

import argparse
import contextlib
import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pandas as pd
from class_subsets import classify_config
from harness import ROOT, publish, run_tables, sets_and_record, shown, two_mode_markdown
from record_candidates import fitted_of_others

import clothscope.classify.feature_sets as feature_sets
from clothscope.core.imageio import read_png, srgb_to_linear
from clothscope.fit.outputs import COMPARISON_FILE
from clothscope.fit.target import SHARE_FLOOR, Target, unexplained_share

MODES = ("without", "with the column")
GAP_PX = 4  # the white gap between the panels of compare.png


def compare_share(compare: Path) -> float:
    """:func:`clothscope.fit.target.unexplained_share` of the photo and preview panels of a ``compare.png``."""
    panels = read_png(compare)[..., :3].astype(np.float64)
    size = (panels.shape[1] - 2 * GAP_PX) // 3
    photo = srgb_to_linear(panels[:, :size])
    fit = srgb_to_linear(panels[:, size + GAP_PX:2 * size + GAP_PX])
    return unexplained_share(fit, Target(photo, np.ones(photo.shape[:2])))


@contextlib.contextmanager
def brdf_columns(columns: tuple[str, ...]) -> Iterator[None]:
    """The feature groups read ``columns`` as the BRDF columns while the block runs."""
    kept = feature_sets.BRDF_COLUMNS
    feature_sets.BRDF_COLUMNS = columns
    try:
        yield
    finally:
        feature_sets.BRDF_COLUMNS = kept


def with_share(run: Path, fitted: pd.DataFrame) -> pd.DataFrame:
    """The fitted table with ``unexplained`` (log share; 0 where an image has no comparison), unless its fits
    recorded their own (``state.json``'s ``unexplained_share``, in the table since the rule passed)."""
    if "unexplained" in fitted.columns:
        return fitted
    shares = []
    for image in fitted["image_id"].astype(str):
        compare = run / "fit" / image / "normals" / COMPARISON_FILE
        shares.append(math.log(max(compare_share(compare), SHARE_FLOOR)) if compare.is_file() else 0.0)
    return fitted.assign(unexplained=shares)


def run_rows(run: Path, spoil_seed: int | None) -> list[dict]:
    """The fitted sets and the record of one run, without the column and with it in the BRDF columns."""
    tables, tiles = run_tables(run)
    tables = {**tables, "fitted": with_share(run, tables["fitted"])}
    if spoil_seed is not None:
        tables, tiles = fitted_of_others(tables, tiles, spoil_seed)
    settings = classify_config()
    test_tiles = settings["test_tiles"] == "mean"  # as the feature_sets rule scores its sets
    base = tuple(c for c in feature_sets.BRDF_COLUMNS if c != "unexplained")
    label = shown(run) + ("" if spoil_seed is None else f" (fitted features of other images, seed {spoil_seed})")
    rows = []
    for mode, columns in zip(MODES, (base, (*base, "unexplained"))):
        with brdf_columns(columns):
            rows += [{"run": label, "mode": mode, **row} for row in sets_and_record(
                tables, tiles, settings, keep=lambda name: name.endswith("fitted"), test_tiles=test_tiles)]
    return rows


def markdown(table: pd.DataFrame) -> str:
    """One line per run and feature set: images right without the column and with it."""
    return two_mode_markdown(table, MODES, "LOOCV images right, the fitted sets and the classifier of record, without "
                             "and with the log share of the photo the fit leaves unexplained among the BRDF columns:")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="run folders (each with features/fitted, features/photo and fit/)")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--name", default="fit_residual")
    parser.add_argument("--fitted-of-others", type=int, metavar="SEED",
                        help="give each image the fitted features of another (a permutation drawn with SEED)")
    args = parser.parse_args()
    table = pd.DataFrame([row for run in args.runs for row in run_rows(ROOT / run, args.fitted_of_others)])
    publish(args.out, args.name, table, markdown(table))


if __name__ == "__main__":
    main()
