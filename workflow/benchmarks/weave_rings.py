"""Benchmark: what the weave rings (``w_*``, the autocorrelation at the canonical period) add, source by source.

    .venv/bin/python workflow/benchmarks/weave_rings.py RUN [RUN ...] [--no-record] [--name weave_rings]

For each run folder (its feature tables written by this version, which holds the ``w_*`` columns), scores the
same LOOCV QDA as the ``feature_sets`` rule, whole images, on the photo's structure and structure + LBP, the
fitted relief's structure + BRDF and structure + LBP + BRDF, and the true relief's structure, each with and
without the rings; and the classifier of record (``classify`` rule, tiles included) with the rings in the
sets of :data:`~clothscope.classify.feature_sets.RING_SOURCES` and with none. Writes
``results/bench/<name>.{csv,md}``. Nothing is chosen here.
"""
from __future__ import annotations

from pathlib import Path

import pandas as pd
from class_subsets import classify_config
from harness import change_lines, record_inputs, record_loocv, run_tables, runs_report, shown

from clothscope.classify.feature_sets import RING_SOURCES, group_columns, usable
from clothscope.classify.loocv import loocv
from clothscope.features.structure import WEAVE_COLUMNS

#: (source, column group) pairs scored with and without the rings.
SCORED = (("photo", "structure"), ("photo", "texture"), ("fitted", "structure_brdf"), ("fitted", "texture_brdf"),
          ("truth", "structure"))


def without_rings(columns: list[str]) -> list[str]:
    """``columns`` less the weave rings (plain or ``<source>.``-prefixed)."""
    return [c for c in columns if c.rsplit(".", 1)[-1] not in WEAVE_COLUMNS]


def set_rows(table: pd.DataFrame, source: str, group: str, settings: dict) -> dict:
    """One source's column group, whole images, scored without and with the rings."""
    rows = usable(table).reset_index()
    with_rings = group_columns(group, rows.columns)
    if not set(WEAVE_COLUMNS) <= set(with_rings):
        raise SystemExit(f"the {source} table has no w_* columns: rerun its features rule with this version")
    scores = {label: loocv(rows, columns, settings["reg"], subspace=settings["subspace"])
              for label, columns in (("without", without_rings(with_rings)), ("with", with_rings))}
    return {"feature_set": f"{group}_{source}", "without": scores["without"].correct, "with": scores["with"].correct,
            "n": scores["with"].n}


def record_row(tables: dict[str, pd.DataFrame], tile_tables: dict[str, pd.DataFrame], settings: dict) -> dict:
    """The classifier of record (tiles included) with no rings, and with the rings of RING_SOURCES."""
    ok, tiles, candidates = record_inputs(tables, tile_tables or None, settings["feature_set"])
    scores = {label: record_loocv(ok, sets, tiles, settings)
              for label, sets in (("without", {k: without_rings(v) for k, v in candidates.items()}), ("with", candidates))}
    return {"feature_set": "classifier of record", "without": scores["without"].correct, "with": scores["with"].correct,
            "n": scores["with"].n}


def run_rows(run: Path, settings: dict, no_record: bool = False) -> list[dict]:
    """Every scored set and (unless ``no_record``) the classifier of record on one run."""
    sources = tuple(s for s in ("fitted", "photo", "truth") if (run / "features" / s / "table.parquet").is_file())
    tables, tile_tables = run_tables(run, sources)
    rows = [set_rows(tables[source], source, group, settings) for source, group in SCORED if source in tables]
    if not no_record:
        rows.append(record_row(tables, tile_tables, settings))
    return [{"run": shown(run), **row} for row in rows]


def markdown(table: pd.DataFrame) -> str:
    """One line per run and feature set: images right without and with the rings, and the difference."""
    lines = [f"LOOCV images right without and with the weave rings `w_*`. Feature sets: whole images; the classifier "
             f"of record as the `classify` rule runs it (tiles included), its rings in the sets of "
             f"{', '.join(RING_SOURCES)} only.", "",
             *change_lines(table, "without", "with")]
    return "\n".join(lines) + "\n"


def main() -> None:
    settings = classify_config()
    runs_report(__doc__, "weave_rings", "run folders (each with features/<source>/table.parquet)",
                lambda run, **options: run_rows(run, settings, **options), markdown,
                flags=(("--no-record", "skip the classifier of record (its two LOOCVs with tiles take minutes per run)"),))


if __name__ == "__main__":
    main()
