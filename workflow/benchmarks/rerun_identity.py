"""Benchmark: does a rerun from scratch reproduce a finished run's per-image outputs, file by file?

    .venv/bin/snakemake --cores 2                       # the reference run (results/)
    .venv/bin/python workflow/benchmarks/rerun_identity.py [--images a,b] [--reference results]

Runs prepare, the three fit stages and the fitted features of ``--images`` (default: one per
class) into a fresh folder (``results/bench/rerun_work``), with the same config and seeds,
and compares every file they write with the reference run's copy: byte for byte, and
where the bytes differ, by content (``loss.csv`` without its ``seconds`` column, which is
wall-clock time; Parquet rows value by value). Writes ``results/bench/rerun_identity.{csv,md}``.
Nothing is chosen here; it states how close two runs of the same code on one machine are.
"""
from __future__ import annotations

import argparse
import filecmp
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
from harness import ROOT, STAGES, SUBSET, publish, shown, snakemake, write_sheet

#: columns of a stage's loss.csv that hold wall-clock time, not results
TIMING_COLUMNS = ("seconds",)


def image_outputs(run: Path, image: str) -> list[Path]:
    """Every file a run wrote for one image up to its fitted feature row, relative to the run folder."""
    folders = [run / "prepared" / image, *(run / "fit" / image / stage for stage in STAGES)]
    files = [p for folder in folders if folder.is_dir() for p in sorted(folder.rglob("*")) if p.is_file()]
    files.append(run / "features" / "fitted" / f"{image}.parquet")
    return [p.relative_to(run) for p in files if p.exists()]


def same_content(a: Path, b: Path) -> tuple[bool, float]:
    """Whether two files hold the same results, and the largest absolute difference of their numbers (0 when equal)."""
    if a.suffix == ".csv":
        left, right = (pd.read_csv(p).drop(columns=list(TIMING_COLUMNS), errors="ignore") for p in (a, b))
    elif a.suffix == ".parquet":
        left, right = pd.read_parquet(a), pd.read_parquet(b)
    else:
        return False, float("nan")
    if list(left.columns) != list(right.columns) or left.shape != right.shape:
        return False, float("nan")
    numeric = left.select_dtypes("number").columns
    gap = float(np.nanmax(np.abs(left[numeric].to_numpy(float) - right[numeric].to_numpy(float)))) if len(numeric) else 0.0
    others = [c for c in left.columns if c not in numeric]
    return bool(gap == 0.0 and left[others].equals(right[others])), gap


def compare(reference: Path, rerun: Path, image: str) -> list[dict]:
    """One row per output file of ``image``: identical bytes, identical content, largest numeric difference."""
    rows = []
    for name in image_outputs(reference, image):
        a, b = reference / name, rerun / name
        if not b.exists():
            rows.append({"image_id": image, "file": str(name), "bytes": False, "content": False, "max_abs_diff": np.nan})
            continue
        identical = filecmp.cmp(a, b, shallow=False)
        content, gap = (True, 0.0) if identical else same_content(a, b)
        rows.append({"image_id": image, "file": str(name), "bytes": identical, "content": content, "max_abs_diff": gap})
    return rows


def summary(table: pd.DataFrame, images: list[str], reference: Path, wall_s: float) -> str:
    """The report: how many files match, and every file that does not."""
    differ = table[~table["content"]]
    lines = [f"Images {', '.join(images)}: prepare, fit (three stages) and fitted features rerun from scratch into a "
             f"fresh folder ({wall_s:.0f} s), compared with `{shown(reference)}`.",
             "",
             f"- files compared: {len(table)}",
             f"- byte-identical: {int(table['bytes'].sum())}",
             f"- same content (`loss.csv` without its wall-clock `seconds` column; Parquet value by value): "
             f"{int(table['content'].sum())}",
             f"- differing: {len(differ)}"]
    if not differ.empty:
        lines += ["", "| image | file | max abs difference |", "|---|---|---|"]
        lines += [f"| {r.image_id} | `{r.file}` | {r.max_abs_diff:.3g} |" for r in differ.itertuples()]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", default=SUBSET, help="comma-separated image ids of config/samples.tsv")
    parser.add_argument("--reference", type=Path, default=ROOT / "results", help="a finished run of config/samples.tsv")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    args = parser.parse_args()
    images = args.images.split(",")
    missing = [i for i in images if not (args.reference / "features" / "fitted" / f"{i}.parquet").exists()]
    if missing:
        raise SystemExit(f"rerun_identity: error: the reference run {args.reference} has no fitted features for "
                         f"{', '.join(missing)}: run the workflow first")
    work = args.out / "rerun_work"
    shutil.rmtree(work, ignore_errors=True)
    sheet = write_sheet(images, work / "samples.tsv")
    targets = [str(work / "features" / "fitted" / f"{i}.parquet") for i in images]
    wall_s = snakemake(["--config", f"samples={sheet}", f"results={work}", "--", *targets], capture=True)
    table = pd.DataFrame([row for image in images for row in compare(args.reference, work, image)])
    publish(args.out, "rerun_identity", table, summary(table, images, args.reference, wall_s))


if __name__ == "__main__":
    main()
