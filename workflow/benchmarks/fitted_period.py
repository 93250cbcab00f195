"""Benchmark: the thread period read from fitted normal maps, strongest relief peak against power times frequency.

    .venv/bin/python workflow/benchmarks/fitted_period.py RUN:SHEET [RUN:SHEET ...] [--name fitted_period]

For each run folder and its sample sheet, every fitted image with a true period is scored as the
accuracy report scores it (:func:`clothscope.evaluate.accuracy.period_error`: against the period
as seen, in the frame the fit saw), once with the strongest peak of the relief spectrum and once
with the peak of most power times frequency (:func:`clothscope.features.period.thread_period`).
Writes ``results/bench/<name>.{csv,md}``. Nothing is chosen here. ``docs/results.md`` lists the
embedded, held-out, three-weave and fresh nine-class runs; ``results/weaves/run_strongest`` is the
three-weave set run with ``prepare: {period_peak: strongest}`` in a config overlay.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import pandas as pd
from harness import ROOT, publish, shown

from clothscope.core.imageio import read_exr
from clothscope.core.truth import truth_paths
from clothscope.evaluate.accuracy import fitted_period_px, period_error, seen_scale, truth_as_fitted
from clothscope.fit.outputs import NORMAL_FILE, STATE_FILE
from clothscope.prepare.image import STATUS_FILE

TOLERANCE = 0.05
RULES = {"strongest": False, "weighted": True}


def run_rows(run: Path, sheet: Path) -> list[dict]:
    """One row per fitted periodic image of a run: its period error under each rule."""
    rows = []
    for sample in pd.read_csv(sheet, sep="\t", dtype=str, keep_default_na=False).itertuples():
        normals = run / "fit" / sample.image_id / "normals"
        status = run / "prepared" / sample.image_id / STATUS_FILE
        if not (normals / NORMAL_FILE).is_file() or not status.is_file():
            continue
        state = json.loads((normals / STATE_FILE).read_text(encoding="utf-8"))
        truth = truth_as_fitted(truth_paths(ROOT / sample.path)["json"], status)
        if state["status"] != "fitted" or not truth.get("thread_period_px"):
            continue
        normal = read_exr(normals / NORMAL_FILE)
        rows.append({"run": shown(run), "image_id": sample.image_id,
                     "fabric_class": sample.fabric_class,
                     **{f"{rule}_error": period_error(fitted_period_px(normal, state["texels_per_pixel"], weighted), truth,
                                                      seen_scale(truth)) for rule, weighted in RULES.items()}})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="RUN:SHEET pairs (run folder, its sample sheet)")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--name", default="fitted_period")
    args = parser.parse_args()
    pairs = [item.split(":", 1) for item in args.runs]
    if any(len(pair) != 2 for pair in pairs):
        parser.error("each run is RUN:SHEET")
    table = pd.DataFrame([row for run, sheet in pairs for row in run_rows(ROOT / run, ROOT / sheet)])
    if table.empty:
        parser.error("no fitted periodic images in the given runs")
    lines = [f"Thread period of fitted normal maps within {TOLERANCE:.0%} of the period as seen:", "",
             "| run | images | strongest relief peak | most power times frequency |", "|---|---|---|---|"]
    for run, group in table.groupby("run", sort=False):
        hits = {rule: int((group[f"{rule}_error"] <= TOLERANCE).sum()) for rule in RULES}
        lines.append(f"| `{run}` | {len(group)} | {hits['strongest']} | {hits['weighted']} |")
    publish(args.out, args.name, table, "\n".join(lines) + "\n", float_format="%.4g")


if __name__ == "__main__":
    main()
