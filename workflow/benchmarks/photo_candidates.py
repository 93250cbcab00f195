"""Benchmark: the classifier of record's choice among the photo's column sets, with and without its spectrum rings.

    .venv/bin/python workflow/benchmarks/photo_candidates.py RUN [RUN ...] [--name photo_candidates]

Needs only each run's photo feature table and its tiles (``features/photo/table.parquet``, made by
``snakemake <run>/features/photo/table.parquet`` with no fit), so fresh sets are scored without fitting
them. For each run, LOOCV with a column set chosen inside each fold by its training images only, as the
``classify`` rule chooses (the config's shrinkage, subspace and ``classify.choice``: ``photo_structure``
unless another set beats it by the sign test), among two candidate lists:

- ``photo's sets``: the photo's sets of the classifier of record, ``photo_structure`` and
  :data:`clothscope.classify.feature_sets.PHOTO_GROUPS`, without ``photo_spectrum`` (the list of 2026-11-28);
- ``with photo_spectrum``: the same and the photo's structure descriptor with its spectrum rings ``p_*``
  (:func:`clothscope.features.structure.spectrum_rings`; a member of the record's vote since 2026-12-07).

The fitted maps' sets are left out: the proxy reads the candidates the folds of the classifier of record
have chosen on the capture-realistic sets (``docs/results.md``). Plain LOOCV of ``photo_structure`` and of
``photo_spectrum`` alone is reported beside them. Writes ``results/bench/<name>.{csv,md}``.
"""
from __future__ import annotations

from pathlib import Path

import pandas as pd
from class_subsets import classify_config
from harness import record_loocv, run_tables, runs_report, shown

from clothscope.classify.feature_sets import PHOTO_GROUPS, joined_table, joined_tiles, source_columns
from clothscope.features.sources import STATUS_OK

#: the candidate lists compared, in the order reported
LISTS = ("photo's sets", "with photo_spectrum")
#: the single sets scored beside them
ALONE = ("photo_structure", "photo_spectrum")


def photo_sets(columns: pd.Index) -> dict[str, list[str]]:
    """The photo's candidate column sets of the classifier of record, ``photo_spectrum`` among them."""
    sets = {"photo_structure": source_columns(columns, "photo", "structure")}
    return sets | {name: source_columns(columns, "photo", group) for name, group in PHOTO_GROUPS.items()}


def photo_inputs(run: Path) -> tuple[pd.DataFrame, pd.DataFrame | None, dict[str, list[str]]]:
    """One run's usable photo rows, their tile rows and :func:`photo_sets` (from the photo tables alone)."""
    tables, tile_tables = run_tables(run, ("photo",))
    joined = joined_table(tables)
    return joined[joined["status"] == STATUS_OK], joined_tiles(tables, tile_tables), photo_sets(joined.columns)


def run_rows(run: Path) -> list[dict]:
    """Images right in one run under each candidate list, and by each single set."""
    ok, tiles, every = photo_inputs(run)
    lists = {LISTS[0]: {k: v for k, v in every.items() if k != "photo_spectrum"}, LISTS[1]: every}
    lists |= {name: {name: every[name]} for name in ALONE}
    settings = classify_config()
    rows = []
    for label, candidates in lists.items():
        result = record_loocv(ok, candidates, tiles, settings)
        chosen = result.selected_counts()
        rows.append({"run": shown(run), "candidates": label, "correct": result.correct, "n": result.n,
                     "folds_chose": chosen})
    return rows


def markdown(table: pd.DataFrame) -> str:
    """Per run, images right under each list and set; then summed over the runs."""
    order = [*LISTS, *ALONE]
    wide = table.pivot(index="run", columns="candidates", values="correct")[order]
    n = table.groupby("run")["n"].first()
    runs = list(dict.fromkeys(table["run"]))
    lines = ["LOOCV, column set chosen inside each fold as the classifier of record chooses (prefer `photo_structure` "
             "unless another beats it by the sign test), among the photo's sets without and with `photo_spectrum`; "
             "then each of two sets alone. Images right.", "",
             "| run | images | " + " | ".join(order) + " | change |", "|---|---|" + "---|" * (len(order) + 1)]
    for run in runs:
        row = wide.loc[run]
        lines.append(f"| `{run}` | {n[run]} | " + " | ".join(str(int(row[c])) for c in order)
                     + f" | {int(row[LISTS[1]] - row[LISTS[0]]):+d} |")
    total = wide.loc[runs].sum()
    lines.append(f"| all | {int(n[runs].sum())} | " + " | ".join(str(int(total[c])) for c in order)
                 + f" | {int(total[LISTS[1]] - total[LISTS[0]]):+d} |")
    chose = table[table["candidates"] == LISTS[1]]
    lines += ["", "Folds chose, with `photo_spectrum` among the candidates:", ""]
    lines += [f"- `{r['run']}`: {r['folds_chose']}" for _, r in chose.iterrows()]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    runs_report(__doc__, "photo_candidates", "run folders with a photo feature table", run_rows, markdown)
