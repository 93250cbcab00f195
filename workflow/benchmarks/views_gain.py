"""Benchmark: what turned and zoomed views (``features.tiles.turns`` and ``zooms``) change, as extra training rows.

    .venv/bin/python workflow/benchmarks/views_gain.py RUN [RUN ...] [--name views_gain]

For each run folder, recomputes every usable image's tile rows from its fitted relief and prepared photo with
the views of :data:`VIEWS` (those of ``config/overlays/views.yaml``) and scores, on the run's feature tables,
the feature-set report's sets and the classifier of record (as the ``classify`` rule runs them) twice: with
the tiles alone and with the tiles and the views. Writes ``results/bench/<name>.{csv,md}``. Nothing is chosen here.
"""
from __future__ import annotations

from pathlib import Path

import pandas as pd
from class_subsets import classify_config
from harness import run_tables, runs_report, sets_and_record, shown, two_mode_markdown, validated_config

from clothscope.features.sources import STATUS_OK, load_normal_input
from clothscope.features.table import structure_settings, tile_rows, tile_settings

#: The views scored: turns (degrees) and zooms, as in ``config/overlays/views.yaml``.
VIEWS = {"turns": (30.0,), "zooms": (1.3, 0.77)}

MODES = ("tiles", "tiles and views")

#: Where a run keeps each source's input folder of one image.
SOURCE_DIRS = {"fitted": ("fit", "normals"), "photo": ("prepared",)}


def source_tiles(run: Path, source: str, images: list[str], features: dict) -> pd.DataFrame:
    """Tile and view rows of ``images`` from one source of ``run`` (the workflow's tile settings plus :data:`VIEWS`)."""
    tiles, structure = tile_settings(features["tiles"] | VIEWS), structure_settings(features)
    top, *below = SOURCE_DIRS[source]
    rows = []
    for image in images:
        loaded = load_normal_input(source, "", run / top / image / Path(*below), features["fitted_field"], features["photo_field"])
        if loaded.status == STATUS_OK:
            rows += tile_rows(image, loaded.field, structure, tiles)
    return pd.DataFrame(rows)


def run_rows(run: Path) -> list[dict]:
    """Every set of one run with the tiles alone and with the views too."""
    features, settings = validated_config()["features"], classify_config()
    tables, _ = run_tables(run, ("fitted", "photo"))
    images = tables["photo"].loc[tables["photo"]["status"] == STATUS_OK, "image_id"].astype(str).tolist()
    with_views = {source: source_tiles(run, source, images, features) for source in tables}
    tiles_only = {source: rows[rows["tile"] < features["tiles"]["grid"] ** 2] for source, rows in with_views.items()}
    return [{"run": shown(run), "mode": mode, **row}
            for mode, tiles in zip(MODES, (tiles_only, with_views))
            for row in sets_and_record(tables, tiles, settings, keep=lambda name: not name.endswith("truth"))]


def markdown(table: pd.DataFrame) -> str:
    """One line per run and feature set: images right with the tiles alone, and with the views too."""
    return two_mode_markdown(table, MODES, f"LOOCV images right, each fold training on its images' tiles, then also on "
                             f"views turned by {', '.join(f'{t:g}' for t in VIEWS['turns'])} degrees and zoomed by "
                             f"{', '.join(f'{z:g}' for z in VIEWS['zooms'])}:")


def main() -> None:
    runs_report(__doc__, "views_gain", "run folders (each with features/<source>/table.parquet, fit/ and prepared/)", run_rows, markdown)


if __name__ == "__main__":
    main()
