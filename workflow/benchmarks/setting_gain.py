"""Benchmark: what a setting changes in the feature-set report and the classifier of record, run by run.

    .venv/bin/python workflow/benchmarks/setting_gain.py BEFORE:AFTER [BEFORE:AFTER ...] [--name setting_gain]
    .venv/bin/python workflow/benchmarks/setting_gain.py --rerun OVERLAY --drop features/photo --drop features/fitted \
        BEFORE:AFTER[:SHEET] ... [--name setting_gain]

Each argument pairs two results folders of the same images: BEFORE made without the setting, AFTER a copy of it
whose workflow reran with the setting's overlay (only the dropped outputs and the rules the setting reaches rerun;
the other fits are reused). Reads both folders' ``reports/feature_sets.csv`` and the classifier of record's
``reports/fitted/accuracy.json`` and writes the images right before and after, per feature set and summed over
the pairs, into ``results/bench/<name>.{csv,md}``; where both runs have ``reports/fit_accuracy.csv``, the text also
says what the setting changed in the fits (re-render PSNR, fitted period). Nothing is chosen here.

With ``--rerun OVERLAY``, each AFTER folder is first made here: BEFORE's ``prepared``, ``fit`` and ``features``
copied in, the ``--drop`` paths or glob patterns under it removed (the outputs the setting changes), then the workflow
run on it with ``config/config.yaml`` and OVERLAY (and ``samples=SHEET`` where the pair names one). An existing AFTER
is replaced.
"""
from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

import pandas as pd
from harness import ROOT, change_lines, publish, shown, snakemake

#: The folders of BEFORE that ``--rerun`` copies into AFTER.
COPIED = ("prepared", "fit", "features")
#: A fitted thread period within this relative error of the truth is counted right (as the accuracy report does).
PERIOD_TOLERANCE = 0.05
#: The row that holds the classifier of record (its figures come from ``reports/fitted/accuracy.json``).
RECORD = "classifier of record"


def run_scores(run: Path) -> pd.DataFrame:
    """Images right and scored per feature set of one run, the classifier of record last."""
    sets = pd.read_csv(run / "reports" / "feature_sets.csv")
    sets = sets[sets["n"] > 0][["feature_set", "correct", "n"]]
    record = json.loads((run / "reports" / "fitted" / "accuracy.json").read_text(encoding="utf-8"))
    return pd.concat([sets, pd.DataFrame([{"feature_set": RECORD, "correct": record["correct"], "n": record["n"]}])],
                     ignore_index=True)


def pair_rows(before: Path, after: Path) -> pd.DataFrame:
    """One row per feature set scored in both runs: images right before and after."""
    joined = run_scores(before).merge(run_scores(after), on="feature_set", suffixes=("_before", "_after"))
    if (joined["n_before"] != joined["n_after"]).any():
        raise SystemExit(f"{shown(before)} and {shown(after)} scored different images: pair runs of the same images")
    return pd.DataFrame({"run": shown(after), "feature_set": joined["feature_set"], "before": joined["correct_before"],
                         "after": joined["correct_after"], "n": joined["n_before"]})


def fit_changes(before: Path, after: Path) -> dict | None:
    """What the setting changed in the fits, from both runs' ``reports/fit_accuracy.csv`` (None without them): the
    images whose re-render PSNR moved, their median PSNR before and after, and the fitted periods within 5%."""
    paths = [run / "reports" / "fit_accuracy.csv" for run in (before, after)]
    if not all(path.is_file() for path in paths):
        return None
    old, new = (pd.read_csv(path).set_index("image_id") for path in paths)
    both = old.merge(new, left_index=True, right_index=True, suffixes=("_before", "_after"))
    moved = both[(both["psnr_db_before"] - both["psnr_db_after"]).abs() > 1e-9]
    periodic = both[both["period_error_before"] >= 0]  # -1: no period to measure (pile)
    return {"run": shown(after), "images": len(both), "refitted_differently": len(moved),
            "psnr_before": float(moved["psnr_db_before"].median()) if len(moved) else float("nan"),
            "psnr_after": float(moved["psnr_db_after"].median()) if len(moved) else float("nan"),
            "periodic": len(periodic),
            **{f"period_within_5pct_{side}": int((periodic[f"period_error_{side}"] <= PERIOD_TOLERANCE).sum())
               for side in ("before", "after")}}


def fit_lines(changes: list[dict]) -> list[str]:
    """A markdown table of :func:`fit_changes` rows (empty without any)."""
    if not changes:
        return []
    lines = ["", "What the setting changed in the fits (`reports/fit_accuracy.csv`): the images whose re-render PSNR moved, "
             "their median PSNR, and the fitted thread periods within 5% of the truth:", "",
             "| run | images | PSNR moved | their median PSNR, before | after | period within 5%, before | after |",
             "|---|---|---|---|---|---|---|"]
    for c in changes:
        psnr = [f"{c[key]:.2f} dB" if c["refitted_differently"] else "-" for key in ("psnr_before", "psnr_after")]
        lines.append(f"| `{c['run']}` | {c['images']} | {c['refitted_differently']} | {psnr[0]} | {psnr[1]} | "
                     f"{c['period_within_5pct_before']}/{c['periodic']} | {c['period_within_5pct_after']}/{c['periodic']} |")
    return lines


def rerun_with(before: Path, after: Path, overlay: Path, drop: list[str], sheet: str | None) -> None:
    """Make ``after`` from ``before``'s prepared photos, fits and features less ``drop``, and run the workflow with ``overlay``."""
    shutil.rmtree(after, ignore_errors=True)
    after.mkdir(parents=True)
    for folder in COPIED:
        shutil.copytree(before / folder, after / folder, symlinks=True)
    for pattern in drop:
        for path in sorted(after.glob(pattern)):
            shutil.rmtree(path, ignore_errors=True)
    config = [f"results={after.relative_to(ROOT)}", *([f"samples={sheet}"] if sheet else [])]
    # the copies carry no Snakemake records, so only the dropped outputs and what follows them by time rerun
    snakemake(["--configfile", "config/config.yaml", str(overlay), "--rerun-triggers", "mtime", "--config", *config])


def rerun_problem(before: str, after: str) -> str | None:
    """Why the folder ``after`` cannot be made from ``before`` (paths under the repository root): a folder to copy is
    missing, or ``after`` is outside the repository."""
    missing = [folder for folder in COPIED if not (ROOT / before / folder).is_dir()]
    if missing:
        return f"{before} has no {', '.join(missing)} folder to copy"
    return None if (ROOT / after).resolve().is_relative_to(ROOT) else f"{after} is outside the repository"


def markdown(table: pd.DataFrame, changes: list[dict]) -> str:
    """Per run and feature set, then summed over the runs: images right before and after, and the change; then what
    the setting changed in the fits (:func:`fit_lines`)."""
    lines = ["LOOCV images right without (before) and with (after) the setting, same images; feature sets "
             "as the `feature_sets` rule scores them, the classifier of record as the `classify` rule does.", "",
             *change_lines(table, "before", "after"), *fit_lines(changes)]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("pairs", nargs="+", help="BEFORE:AFTER results folders (paths under the repository root), "
                        "with --rerun also BEFORE:AFTER:SHEET (the sample sheet of a run not made from config/samples.tsv)")
    parser.add_argument("--rerun", type=Path, help="config overlay: make each AFTER from BEFORE with it first")
    parser.add_argument("--drop", action="append", default=[],
                        help="with --rerun: a path or glob pattern under AFTER removed before the run "
                        "(for example 'fit/*/normals'; repeat for more)")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--name", default="setting_gain")
    args = parser.parse_args()
    pairs = [pair.split(":") for pair in args.pairs]
    if any(len(pair) != 2 and not (args.rerun and len(pair) == 3) for pair in pairs):
        raise SystemExit("each pair is BEFORE:AFTER, two results folders joined by one colon (with --rerun, :SHEET may follow)")
    if args.rerun:
        for before, after, *_ in pairs:
            if problem := rerun_problem(before, after):
                raise SystemExit(f"{before}:{after}: {problem}")
        for before, after, *sheet in pairs:
            rerun_with(ROOT / before, ROOT / after, args.rerun, args.drop, sheet[0] if sheet else None)
    table = pd.concat([pair_rows(ROOT / before, ROOT / after) for before, after, *_ in pairs], ignore_index=True)
    changes = [c for before, after, *_ in pairs if (c := fit_changes(ROOT / before, ROOT / after))]
    publish(args.out, args.name, table, markdown(table, changes))


if __name__ == "__main__":
    main()
