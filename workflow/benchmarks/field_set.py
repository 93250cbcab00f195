"""Benchmark: the capture-realistic field set: what the generator drew per class, its render time, and thread periods.

    .venv/bin/snakemake --cores 2 field_set
    .venv/bin/snakemake --cores 2 --config samples=results/field/samples.tsv results=results/field/run
    .venv/bin/python workflow/benchmarks/field_set.py [--field results/field] [--run results/field/run]

Reads each image's truth record (the generator's draws and render seconds) and, where the
workflow has run on the set, the period ``prepare`` measured at native resolution
(``prepared/<id>/status.json``, ``scale.native_period_px``) against the true period as seen
(the nominal period times :func:`clothscope.evaluate.seen_scale`, the mean magnification the
folds give; knits: wale or course, whichever is closer). Writes ``results/bench/field_set.{csv,md}``. Nothing
is chosen here; the classification figures of the set are in the run's feature-set report.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import pandas as pd
from harness import ROOT, publish

from clothscope.evaluate import seen_scale
from clothscope.synth.generate import truth_paths

TOLERANCE = 0.05


def image_rows(field: Path, run: Path) -> pd.DataFrame:
    """One row per field image: its draws, render time and (when prepared) the measured native period."""
    sheet = pd.read_csv(field / "samples.tsv", sep="\t", dtype=str, keep_default_na=False)
    rows = []
    for image_id, path in zip(sheet["image_id"], sheet["path"]):
        truth = json.loads(truth_paths(ROOT / path)["json"].read_text(encoding="utf-8"))
        draw = truth["draw"]
        seen = seen_scale(truth)  # folds bring the cloth nearer or farther than the nominal plane
        periods = [p * seen for p in (truth["thread_period_px"], truth["course_period_px"]) if p]
        status = run / "prepared" / image_id / "status.json"
        measured = json.loads(status.read_text())["scale"].get("native_period_px") if status.is_file() else None
        error = min(abs(measured / p - 1) for p in periods) if measured and periods else None
        rows.append({"image_id": image_id, "fabric_class": truth["fabric_class"], "weave": draw["weave_variant"],
                     "capture": draw["capture"], "resolution": draw["resolution"], "fov_deg": draw["fov_deg"],
                     "tilt_deg": draw["tilt_deg"], "period_px": truth["thread_period_px"], "colour": draw["colour_scheme"],
                     "hairiness": draw["hairiness"], "slub": draw["slub"], "defocus_px": draw["defocus_px"],
                     "jpeg_quality": draw["jpeg_quality"], "render_s": truth["provenance"]["render_seconds"],
                     "prepared": status.is_file(), "periodic": truth["periodic"],
                     "seen_period_px": periods[0] if periods else None, "native_period_px": measured,
                     "period_error": error})
    return pd.DataFrame(rows)


def span(values: pd.Series, digits: int = 0) -> str:
    """``min-max`` of a numeric column, or ``-`` when it is empty."""
    values = values.dropna()
    return "-" if values.empty else f"{values.min():.{digits}f}-{values.max():.{digits}f}"


def per_class(table: pd.DataFrame) -> pd.DataFrame:
    """The generator's draws summarised per class."""
    return pd.DataFrame([{
        "class": fabric, "images": len(group), "weaves": ", ".join(sorted(set(group["weave"]))),
        "captures": ", ".join(sorted(set(group["capture"]))), "native px": span(group["resolution"]),
        "period px": span(group["period_px"], 1), "colours": ", ".join(sorted(set(group["colour"]))),
        "JPEG q": span(group["jpeg_quality"]), "render s (median)": f"{group['render_s'].median():.0f}",
    } for fabric, group in table.groupby("fabric_class", sort=False)])


def period_summary(table: pd.DataFrame) -> str:
    """How often ``prepare`` found the true period within the tolerance, over periodic prepared images."""
    periodic = table[table["periodic"] & table["prepared"]]
    if periodic.empty:
        return "Thread periods: not measured (the workflow has not run on the set)."
    found = periodic["native_period_px"].notna()
    within = (periodic["period_error"] < TOLERANCE).sum()
    return (f"Thread period measured by `prepare` at native resolution: within {TOLERANCE:.0%} of the truth for "
            f"{within}/{len(periodic)} periodic images ({within / len(periodic):.0%}); no lattice found for "
            f"{(~found).sum()}; median error where found {periodic.loc[found, 'period_error'].median():.1%}.")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--field", type=Path, default=ROOT / "results" / "field")
    parser.add_argument("--run", type=Path, default=ROOT / "results" / "field" / "run")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    args = parser.parse_args()
    table = image_rows(args.field, args.run)
    summary = per_class(table)
    text = "\n".join([
        f"{len(table)} images, {table['fabric_class'].nunique()} classes; render time {table['render_s'].sum() / 60:.1f} min "
        f"in all (median {table['render_s'].median():.0f} s per image, 2 threads).", "",
        summary.to_markdown(index=False), "", period_summary(table), ""])
    publish(args.out, "field_set", table, text, float_format="%.4g")


if __name__ == "__main__":
    main()
