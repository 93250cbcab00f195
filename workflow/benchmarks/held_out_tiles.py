"""Benchmark: an image scored by its whole map's row, or by the mean posterior of that row and its tiles.

    .venv/bin/python workflow/benchmarks/held_out_tiles.py RUN [RUN ...] [--name held_out_tiles]

For each run, the same LOOCV twice on the same feature tables, with ``classify.test_tiles`` ``none`` and
``mean`` (training rows, shrinkage, subspace and the inner choice are the config's either way):

- ``photo's sets``: the classifier of record's choice among the photo's column sets (``photo_structure``
  preferred unless another beats it by the sign test; the list of ``photo_candidates.py`` without the spectrum
  rings). It needs only the photo's feature table and tiles, so fresh sets are scored without a fit;
- ``photo_structure``: that set alone;
- ``classifier of record``: where the run has fitted maps, the ``classify`` rule's candidates over the fitted
  and photo tables (information beside the proxy above).

Writes ``results/bench/<name>.{csv,md}``.
"""
from __future__ import annotations

from pathlib import Path

import pandas as pd
from class_subsets import classify_config
from harness import record_inputs, record_loocv, run_tables, runs_report, shown
from photo_candidates import photo_inputs

#: how the held-out image is scored, in the order reported
MODES = ("whole row", "mean with tiles")


def scored_lists(run: Path, settings: dict) -> list[tuple[str, pd.DataFrame, pd.DataFrame | None, dict[str, list[str]]]]:
    """``(label, rows, tiles, candidates)`` of each LOOCV scored on one run."""
    ok, tiles, sets = photo_inputs(run)
    every = {name: columns for name, columns in sets.items() if name != "photo_spectrum"}
    lists = [("photo's sets", ok, tiles, every), ("photo_structure", ok, tiles, {"photo_structure": every["photo_structure"]})]
    if (run / "features" / "fitted" / "table.parquet").is_file():
        lists.append(("classifier of record", *record_inputs(*run_tables(run), settings["feature_set"])))
    return lists


def run_rows(run: Path) -> list[dict]:
    """Images right under each list, scored both ways."""
    settings = classify_config()
    rows = []
    for label, ok, tiles, candidates in scored_lists(run, settings):
        for mode in MODES:
            result = record_loocv(ok, candidates, tiles, settings, test_tiles=mode == MODES[1])
            rows.append({"run": shown(run), "candidates": label, "mode": mode, "correct": result.correct, "n": result.n})
    return rows


def markdown(table: pd.DataFrame) -> str:
    """Per run and list, images right both ways; then the photo's sets summed over the runs."""
    wide = table.pivot_table(index=["run", "candidates"], columns="mode", values="correct", sort=False).reset_index()
    n = table.groupby("run")["n"].first()
    lines = ["LOOCV images right, each held-out image scored by its whole row or by the mean posterior of its row and "
             "its tiles (`classify.test_tiles`); training rows and the inner choice are the same both ways.", "",
             "| run | candidates | images | " + " | ".join(MODES) + " | change |", "|---|---|---|---|---|---|"]
    for _, r in wide.iterrows():
        change = int(r[MODES[1]] - r[MODES[0]])
        lines.append(f"| `{r['run']}` | {r['candidates']} | {n[r['run']]} | {int(r[MODES[0]])} | {int(r[MODES[1]])} "
                     f"| {change:+d} |")
    proxy = wide[wide["candidates"] == "photo's sets"]
    total = proxy[list(MODES)].sum()
    lines.append(f"| all | photo's sets | {int(n[proxy['run']].sum())} | {int(total[MODES[0]])} | {int(total[MODES[1]])} "
                 f"| {int(total[MODES[1]] - total[MODES[0]]):+d} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    runs_report(__doc__, "held_out_tiles", "run folders with a photo feature table", run_rows, markdown)
