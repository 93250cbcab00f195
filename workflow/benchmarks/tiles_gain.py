"""Benchmark: what training on tiles (``features.tiles``) changes, feature set by feature set, on finished runs.

    .venv/bin/python workflow/benchmarks/tiles_gain.py RUN [RUN ...] [--name tiles_gain]

For each run folder, the feature-set report (:func:`clothscope.classify.feature_sets.compare_feature_sets`,
the ``feature_sets`` rule's LOOCV) and the classifier of record (``classify.feature_set`` on fitted maps
with the photo beside them, as the ``classify`` rule runs it) are scored twice on the same feature
tables: on whole images only, and with every fold also training on the tiles of its training images.
The tile tables must be there (``features.tiles.grid`` > 0 when the run was made). Writes
``results/bench/<name>.{csv,md}``: per run, feature set and mode, images right. Nothing is chosen here.
"""
from __future__ import annotations

from pathlib import Path

import pandas as pd
from class_subsets import classify_config
from harness import record_inputs, record_loocv, run_tables, runs_report, shown

from clothscope.classify.feature_sets import compare_feature_sets

MODES = ("whole images", "with tiles")


def record_row(tables: dict[str, pd.DataFrame], tile_tables: dict[str, pd.DataFrame] | None, settings: dict) -> dict:
    """The classifier of record's LOOCV on one run's fitted and photo tables (tiles or none)."""
    ok, tiles, candidates = record_inputs(tables, tile_tables, settings["feature_set"])
    result = record_loocv(ok, candidates, tiles, settings)
    return {"feature_set": "classifier of record", "correct": result.correct, "n": result.n}


def run_rows(run: Path, settings: dict) -> list[dict]:
    """Every feature set and the classifier of record on one run, in both modes."""
    sources = tuple(s for s in ("fitted", "photo", "truth") if (run / "features" / s / "table.parquet").is_file())
    tables, tile_tables = run_tables(run, sources)
    if set(tile_tables) != set(sources):
        raise SystemExit(f"{shown(run)}: no tile tables for {', '.join(sorted(set(sources) - set(tile_tables)))}; "
                         "rerun it with features.tiles.grid > 0")
    rows = []
    for mode, tiles in zip(MODES, (None, tile_tables)):
        report = compare_feature_sets(tables, settings["reg"], settings["subspace"], tiles)
        scored = report[report["status"] == "ok"]
        rows += [{"run": shown(run), "mode": mode, "feature_set": r.feature_set, "correct": int(r.correct), "n": int(r.n)}
                 for r in scored.itertuples()]
        rows.append({"run": shown(run), "mode": mode, **record_row(tables, tiles, settings)})
    return rows


def markdown(table: pd.DataFrame) -> str:
    """One line per run and feature set: images right on whole images, and with tiles."""
    wide = table.pivot_table(index=["run", "feature_set"], columns="mode", values="correct", sort=False).reset_index()
    n = table.groupby("run")["n"].max()
    lines = ["LOOCV images right, on whole images only and with each fold also training on its training images' tiles:", "",
             "| run | feature set | whole images | with tiles |", "|---|---|---|---|"]
    lines += [f"| `{r['run']}` | {r['feature_set']} | {int(r[MODES[0]])}/{n[r['run']]} | {int(r[MODES[1]])}/{n[r['run']]} |"
              for _, r in wide.iterrows()]
    return "\n".join(lines) + "\n"


def main() -> None:
    settings = classify_config()
    runs_report(__doc__, "tiles_gain", "run folders (each with features/<source>/table.parquet and tiles/)", lambda run: run_rows(run, settings), markdown)


if __name__ == "__main__":
    main()
