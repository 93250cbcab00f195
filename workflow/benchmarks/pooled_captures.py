"""Benchmark: every fixed feature set on several field runs pooled, by the capture that took each photo.

The hidden real photos this project is scored on include microscope close-ups of weaves, taken
under a ring or coaxial light at the lens. The field sets draw five captures per class
(``clothscope.synth.field.CAPTURES``), too few of one kind per set for a LOOCV of its own, so this
pools the feature tables of several runs of the same classes (image ids prefixed by the run) and
scores every fixed feature set of ``results/reports/feature_sets.md`` on the pooled images of the
macro captures (ring, coaxial), of the phone captures (flash, lamp, window) and on all of them.
The capture of each image comes from its ground-truth record (``draw.capture``).

    .venv/bin/python workflow/benchmarks/pooled_captures.py [--set RUN SHEET ...] [--each] [--name pooled_captures]

Default: the four three-weave runs (seeds 20261203, 20261208, 20261226, 20261227). Writes
``results/bench/<name>.{csv,md}``. Nothing is chosen here.
``--each`` also scores every capture on its own; a group with no images is left out.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import pandas as pd
from harness import ROOT, publish, shown, validated_config
from pooled_sets import SOURCES, read_tables

from clothscope.classify.feature_sets import FEATURE_SETS, compare_feature_sets
from clothscope.synth.field import CAPTURES

#: Capture groups scored, by the field generator's capture names (None: every image).
GROUPS = {"macro (ring, coaxial)": ("macro_ring", "macro_coaxial"),
          "phone (flash, lamp, window)": ("phone_flash", "phone_lamp", "phone_window"),
          "all": None}
#: The feature sets scored: every fixed one (the ``auto`` sets choose inside each fold and are left out).
FIXED_SETS = tuple(feature_set for feature_set in FEATURE_SETS if not feature_set.name.startswith("auto"))
#: The three-weave runs of the project and their sample sheets.
WEAVE_RUNS = (("results/weaves/run", "results/weaves/field/samples.tsv"),
              ("results/weaves_confirm/run", "results/weaves_confirm/field/samples.tsv"),
              ("results/weaves_fresh/run", "results/weaves_fresh/field/samples.tsv"),
              ("results/weaves_period/run", "results/weaves_period/field/samples.tsv"))


def captures(sheet: Path) -> dict[str, str]:
    """Image id to the capture its ground-truth record names, for every image of a field sheet."""
    found = {}
    for row in pd.read_csv(sheet, sep="\t", dtype=str).itertuples():
        record = Path(row.path).with_suffix(".truth.json")
        if not record.is_absolute():
            record = ROOT / record
        if not record.is_file():
            raise SystemExit(f"pooled_captures: error: {shown(record)} not found (is {shown(sheet)} a field sheet?)")
        found[row.image_id] = str(json.loads(record.read_text())["draw"]["capture"])
    return found


def pooled(runs: list[tuple[Path, Path]]) -> dict[str, pd.DataFrame]:
    """Every run's tables stacked per source, ids prefixed by the run's position, with a ``capture`` column."""
    stacked: dict[str, list[pd.DataFrame]] = {source: [] for source in SOURCES}
    for k, (run, sheet) in enumerate(runs):
        capture_of = captures(sheet)
        for source, table in read_tables(run).items():
            stacked[source].append(table.assign(capture=table["image_id"].map(capture_of),
                                                image_id=f"{k}:" + table["image_id"].astype(str)))
    return {source: pd.concat(tables, ignore_index=True) for source, tables in stacked.items()}


def capture_groups(each: bool) -> dict[str, tuple[str, ...] | None]:
    """The groups scored: :data:`GROUPS`, and with ``each`` every capture of the field generator alone."""
    return GROUPS | ({name: (name,) for name in CAPTURES} if each else {})


def summary(table: pd.DataFrame, runs: list[tuple[Path, Path]]) -> str:
    """The Markdown report: one row per feature set, one column per capture group."""
    wide = table.pivot(index="feature_set", columns="captures", values="cell").reindex(table["feature_set"].unique())
    return ("# Feature sets by capture, field runs pooled\n\n"
            "LOOCV QDA with the workflow's classifier settings, whole images (no tiles), on the pooled images of "
            + ", ".join(f"`{shown(run)}`" for run, _ in runs)
            + ". Cells: correct / images (accuracy, 95% Wilson interval); chance is one over the number of classes.\n\n"
            + wide[list(table["captures"].unique())].to_markdown() + "\n")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", nargs=2, action="append", metavar=("RUN", "SHEET"), dest="sets",
                        help="a run folder and the field sheet it was run on (repeat; default: the four weave runs)")
    parser.add_argument("--each", action="store_true", help="also score every capture on its own")
    parser.add_argument("--name", default="pooled_captures", help="report name under results/bench/")
    args = parser.parse_args()
    runs = [(ROOT / run, ROOT / sheet) for run, sheet in (args.sets or WEAVE_RUNS)]
    classify = validated_config()["classify"]
    tables = pooled(runs)
    rows = []
    reports: dict[frozenset[str], pd.DataFrame] = {}  # a group holding the same images as an earlier one is not scored again
    for group, names in capture_groups(args.each).items():
        chosen = {source: t if names is None else t[t["capture"].isin(names)] for source, t in tables.items()}
        if min(len(t) for t in chosen.values()) == 0:
            continue
        images = frozenset(next(iter(chosen.values()))["image_id"])
        if images not in reports:
            reports[images] = compare_feature_sets(chosen, classify["reg"], classify["subspace"], feature_sets=FIXED_SETS)
        report = reports[images]
        for row in report[report["status"] == "ok"].itertuples():
            rows.append({"captures": group, "feature_set": row.feature_set, "correct": int(row.correct), "n": int(row.n),
                         "accuracy": float(row.accuracy), "chance": float(row.chance),
                         "cell": f"{row.correct}/{row.n} ({100 * row.accuracy:.1f}%, "
                                 f"{100 * row.wilson_low:.0f}-{100 * row.wilson_high:.0f}%)"})
        print(f"{group}: scored", flush=True)
    table = pd.DataFrame(rows)
    publish(ROOT / "results" / "bench", args.name, table.drop(columns="cell"), summary(table, runs), float_format="%.4f")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
