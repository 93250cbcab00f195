"""Benchmark: the capture-realistic field set: what the generator drew per class, its render time, and thread periods.

    .venv/bin/snakemake --cores 2 field_set
    .venv/bin/snakemake --cores 2 --config samples=results/field/samples.tsv results=results/field/run
    .venv/bin/python workflow/benchmarks/field_set.py [--field results/field] [--run results/field/run]

Reads each image's truth record (the generator's draws and render seconds) and, where the
workflow has run on the set, the period ``prepare`` measured at native resolution
(``prepared/<id>/status.json``, ``scale.native_period_px``) against the true period as seen
in the centred ``prepare.period_window`` it is read on (the nominal period times
:func:`clothscope.evaluate.accuracy.window_seen_scale`, the mean magnification the folds give there; knits: wale
or course, whichever is closer). The period is also measured here on the luminance and on the shading with the yarn
colours divided out (``prepare.period_field``), taking the strongest peak or the one with the most
power times frequency (``prepare.period_peak``). Writes ``results/bench/<name>.{csv,md}`` and
``<name>.jpg``, the centred 512 px of every image, one row per class.
The design images of ``period_field`` are one per class from seed 20261202:
``.venv/bin/snakemake --cores 2 field_set --configfile config/config.yaml
config/overlays/field_design.yaml``, summarised with ``--field results/field_design/field
--run results/field_design/run --name field_set_design``. Nothing
is chosen here; the classification figures of the set are in the run's feature-set report.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd
from harness import ROOT, publish, validated_config
from PIL import Image

from clothscope.core.atomic import write_with
from clothscope.core.config import schema_defaults
from clothscope.core.imageio import decode_image
from clothscope.core.truth import truth_paths
from clothscope.evaluate.accuracy import window_seen_scale
from clothscope.features.structure import StructureSettings
from clothscope.prepare.image import STATUS_FILE, native_period

TOLERANCE = 0.05
#: a period read this many times too long is a colour or weave repeat: the crop then leaves the threads too fine to fit
TOO_LONG = 1.8
#: a period read this many times too short is a harmonic: the crop then leaves few, large threads
TOO_SHORT = 0.6
#: (prepare.period_field, prepare.period_peak) pairs the period is measured with here
MEASURED = (("luminance", "weighted"), ("shading", "strongest"), ("shading", "weighted"), ("shading", "axes"))
FIELDS = {"luminance": "luminance", "shading": "shading with yarn colours divided out"}
PEAKS = {"strongest": "strongest peak", "weighted": "peak with the most power times frequency",
         "axes": "peak with the most power times frequency along the yarn axes"}

#: decode_image limits: the config schema's prepare defaults
DECODE = tuple(schema_defaults()["prepare"][k] for k in ("min_input_px", "max_megapixels", "clip_threshold"))


def image_rows(field: Path, run: Path) -> pd.DataFrame:
    """One row per field image: its draws, render time and (when prepared) the measured native period."""
    rows = []
    config = validated_config()
    lattice, window = StructureSettings(**config["features"]["structure"]), config["prepare"]["period_window"]
    for path in sorted(field.glob("*/*.jpg")):
        image_id = path.stem
        truth = json.loads(truth_paths(path)["json"].read_text(encoding="utf-8"))
        draw = truth["draw"]
        seen = window_seen_scale(truth, window)  # folds bring the cloth nearer or farther than the nominal plane
        periods = [p * seen for p in (truth["thread_period_px"], truth["course_period_px"]) if p]
        status = run / "prepared" / image_id / STATUS_FILE
        measured = json.loads(status.read_text())["scale"].get("native_period_px") if status.is_file() else None
        ratio = period_ratio(measured, periods) if periods else None
        error = None if ratio is None else abs(ratio - 1)
        by_field = {}
        if periods:
            rgb = decode_image(path, *DECODE).rgb
            by_field = {f"{name}_{peak}": period_ratio(native_period(rgb, window, lattice, name, peak), periods)
                        for name, peak in MEASURED}
        rows.append({"image_id": image_id, "fabric_class": truth["fabric_class"], "weave": draw["weave_variant"],
                     "capture": draw["capture"], "resolution": draw["resolution"], "fov_deg": draw["fov_deg"],
                     "tilt_deg": draw["tilt_deg"], "period_px": truth["thread_period_px"], "colour": draw["colour_scheme"],
                     "hairiness": draw["hairiness"], "slub": draw["slub"], "defocus_px": draw["defocus_px"],
                     "jpeg_quality": draw["jpeg_quality"], "render_s": truth["provenance"]["render_seconds"],
                     "prepared": status.is_file(), "periodic": truth["periodic"],
                     "seen_period_px": periods[0] if periods else None, "native_period_px": measured,
                     "period_error": error, "period_ratio": measured / periods[0] if measured and periods else None,
                     **{f"{name}_period_ratio": r for name, r in by_field.items()}})
    return pd.DataFrame(rows)


def period_ratio(measured: float | None, periods: list[float]) -> float | None:
    """A measured period over the closest true one; None when nothing was measured."""
    return min((measured / p for p in periods), key=lambda r: abs(r - 1)) if measured else None


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


def within(errors: pd.Series) -> str:
    """``k/n (p%)`` of errors below the tolerance, counting a missing measurement as a miss."""
    hits = int((errors.fillna(np.inf) < TOLERANCE).sum())
    return f"{hits}/{len(errors)} ({hits / len(errors):.0%})"


def ratio_counts(ratios: pd.Series) -> str:
    """Within the tolerance, read too long and too short, out of all images, from measured/true period ratios."""
    found = ratios.dropna()
    return (f"{within((ratios - 1).abs())} within {TOLERANCE:.0%}, {int((found >= TOO_LONG).sum())} at least {TOO_LONG:g} "
            f"times too long, {int((found <= TOO_SHORT).sum())} at most {TOO_SHORT:g} times too short, "
            f"{int(ratios.isna().sum())} without a lattice")


def period_summary(table: pd.DataFrame) -> str:
    """How often the thread period was found within the tolerance, per field it is measured on and as prepared."""
    periodic = table[table["periodic"]]
    lines = [f"Thread period at native resolution (centred 1024 px) within {TOLERANCE:.0%} of the period as seen, "
             f"over {len(periodic)} periodic images:",
             *[f"- on the {FIELDS[name]}, {PEAKS[peak]}: {ratio_counts(periodic[f'{name}_{peak}_period_ratio'])}"
               for name, peak in MEASURED]]
    prepared = periodic[periodic["prepared"]]
    if prepared.empty:
        lines.append("- as recorded by the workflow's `prepare`: not measured (the workflow has not run on the set)")
    else:
        too_long = int((prepared["period_ratio"] >= TOO_LONG).sum())
        lines.append(f"- as recorded by the workflow's `prepare` (`scale.native_period_px`): "
                     f"{within(prepared['period_error'])}; no lattice found for {prepared['native_period_px'].isna().sum()}; "
                     f"read at least {TOO_LONG:g} times too long (a colour or weave repeat, so the crop leaves the threads "
                     f"too fine to fit) for {too_long}")
    return "\n".join(lines)


def contact_sheet(field: Path, target: Path, tile: int = 256) -> None:
    """A JPEG grid of the centred 512 px of every image, one row per class."""
    rows = [sorted(folder.glob("*.jpg")) for folder in sorted(p for p in field.iterdir() if p.is_dir())]
    rows = [row for row in rows if row]
    sheet = Image.new("RGB", (tile * max(map(len, rows)), tile * len(rows)), "white")
    for r, row in enumerate(rows):
        for c, path in enumerate(row):
            with Image.open(path) as photo:
                side = min(photo.size)
                half = min(256, side // 2)
                box = (photo.width // 2 - half, photo.height // 2 - half, photo.width // 2 + half, photo.height // 2 + half)
                sheet.paste(photo.convert("RGB").crop(box).resize((tile, tile), Image.Resampling.LANCZOS), (c * tile, r * tile))
    write_with(target, lambda tmp: sheet.save(tmp, "JPEG", quality=85))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--field", type=Path, default=ROOT / "results" / "field")
    parser.add_argument("--run", type=Path, default=ROOT / "results" / "field" / "run")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--name", default="field_set", help="report name (field_set_design for the design images)")
    args = parser.parse_args()
    table = image_rows(args.field, args.run)
    summary = per_class(table)
    text = "\n".join([
        f"{len(table)} images, {table['fabric_class'].nunique()} classes; render time {table['render_s'].sum() / 60:.1f} min "
        f"in all (median {table['render_s'].median():.0f} s per image, 2 threads).", "",
        summary.to_markdown(index=False), "", period_summary(table), ""])
    publish(args.out, args.name, table, text, float_format="%.4g")
    contact_sheet(args.field, args.out / f"{args.name}.jpg")


if __name__ == "__main__":
    main()
