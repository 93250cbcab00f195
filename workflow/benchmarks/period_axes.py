"""Benchmark: the thread period from the peaks along the yarn axes (``prepare.period_peak: axes``) against another pick.

    .venv/bin/python workflow/benchmarks/period_axes.py --set RUN AXES_RUN TRUTH [--set ...] [--name period_axes]
    .venv/bin/python workflow/benchmarks/period_axes.py --native FIELD [FIELD ...] [--name period_axes_native]

Each set is a run whose photos ``prepare`` read with one peak pick (``RUN``), the same photos prepared again with
``axes`` (``AXES_RUN``; ``RUN`` prepared for example with ``config/overlays/period_weighted.yaml``) and the folder of their truth records
(``TRUTH/<class>/<id>.*`` beside ``<id>.truth.json``). Per set and run:

- the periodic photos whose recorded native period (``scale.native_period_px`` of ``prepared/<id>/status.json``)
  lies within 5% of the truth as seen (:func:`clothscope.evaluate.accuracy.seen_scale`; the closer of the thread
  and course periods);
- the classifier of record's proxy on the run's photo tables: LOOCV with the column set chosen inside each fold among
  the photo's sets, each image scored as the config's ``classify.test_tiles`` says (``held_out_tiles.py``'s
  ``photo's sets``).

With ``--native``, no run is needed: each periodic photo of each field folder is decoded and its native period read
both ways, ``weighted`` and ``axes``, as ``prepare`` would (the config's ``prepare.period_window`` and
``period_field``); the report then gives periods
within 5% only (how the pick's settings were chosen, on sets no confirmation used). Writes
``results/bench/<name>.{csv,md}``.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import pandas as pd
from class_subsets import classify_config
from field_set import DECODE, TOLERANCE, period_ratio
from harness import ROOT, publish, record_loocv, shown, validated_config
from held_out_tiles import scored_lists

from clothscope.core.imageio import decode_image
from clothscope.evaluate.accuracy import seen_scale
from clothscope.features.structure import StructureSettings
from clothscope.prepare.image import STATUS_FILE, native_period

#: the two runs of a set, in the order reported
RUNS = ("run", "axes")


def truth_records(truth: Path) -> dict[str, dict]:
    """Truth record of each periodic photo under ``truth``, by image id."""
    records = {}
    for path in sorted(truth.glob("*/*.truth.json")):
        record = json.loads(path.read_text(encoding="utf-8"))
        if record.get("periodic"):
            records[path.name.removesuffix(".truth.json")] = record
    return records


def is_within(measured: float | None, record: dict) -> bool:
    """Whether a native period lies within :data:`TOLERANCE` of the truth as seen (thread or course period)."""
    seen = seen_scale(record)
    ratio = period_ratio(measured, [p * seen for p in (record.get("thread_period_px"), record.get("course_period_px")) if p])
    return ratio is not None and abs(ratio - 1) <= TOLERANCE


def periods_within(run: Path, records: dict[str, dict]) -> int:
    """Periodic photos whose period ``prepare`` recorded in ``run`` lies within :data:`TOLERANCE` of the truth."""
    within = 0
    for image_id, record in records.items():
        status = run / "prepared" / image_id / STATUS_FILE
        scale = (json.loads(status.read_text(encoding="utf-8")).get("scale") or {}) if status.is_file() else {}
        within += is_within(scale.get("native_period_px"), record)
    return within


def native_rows(field: Path) -> dict:
    """Periodic photos of a field folder, and those whose native period each pick reads within 5% of the truth."""
    config = validated_config()
    lattice, prepare = StructureSettings(**config["features"]["structure"]), config["prepare"]
    records = truth_records(field)
    row = {"set": shown(field), "periodic": 0, "weighted": 0, "axes": 0}
    for path in sorted(field.glob("*/*.jpg")):
        record = records.get(path.stem)
        if record is None:  # not periodic
            continue
        rgb = decode_image(path, *DECODE).rgb
        row["periodic"] += 1
        for peak in ("weighted", "axes"):
            period = native_period(rgb, prepare["period_window"], lattice, prepare["period_field"], peak)
            row[peak] += is_within(period, record)
    return row


def proxy_correct(run: Path, settings: dict) -> tuple[int, int]:
    """Images right, and images, of the classifier of record's proxy on the run's photo tables."""
    _, ok, tiles, candidates = scored_lists(run, settings)[0]
    result = record_loocv(ok, candidates, tiles, settings)
    return result.correct, result.n


def set_rows(runs: tuple[Path, Path], truth: Path) -> list[dict]:
    """One row per run of a set: its periods within 5% and its proxy's images right."""
    records = truth_records(truth)
    settings = classify_config()
    rows = []
    for label, run in zip(RUNS, runs):
        correct, n = proxy_correct(run, settings)
        rows.append({"set": shown(runs[0]), "run": label, "folder": shown(run), "periodic": len(records),
                     "period_within_5pct": periods_within(run, records), "proxy_correct": correct, "images": n})
    return rows


def markdown(table: pd.DataFrame) -> str:
    """Per set, both runs' periods within 5% and proxy images right; then summed."""
    lines = ["Periodic photos whose `prepare` period lies within 5% of the truth as seen, and images right by the "
             "classifier of record's proxy (the photo's sets chosen inside each fold, scored as `classify.test_tiles` "
             "says), with the run's period pick and with `axes`.", "",
             "| set | periodic | within 5%, run | within 5%, axes | images | proxy, run | proxy, axes |",
             "|---|---|---|---|---|---|---|"]
    wide = table.pivot(index="set", columns="run", values=["period_within_5pct", "proxy_correct"])
    first = table.groupby("set")[["periodic", "images"]].first()
    sets = list(dict.fromkeys(table["set"]))
    for name in sets:
        w, f = wide.loc[name], first.loc[name]
        lines.append(f"| `{name}` | {f['periodic']} | {w[('period_within_5pct', 'run')]} | "
                     f"{w[('period_within_5pct', 'axes')]} | {f['images']} | {w[('proxy_correct', 'run')]} | "
                     f"{w[('proxy_correct', 'axes')]} |")
    total, count = wide.loc[sets].sum(), first.loc[sets].sum()
    lines.append(f"| all | {count['periodic']} | {total[('period_within_5pct', 'run')]} | "
                 f"{total[('period_within_5pct', 'axes')]} | {count['images']} | {total[('proxy_correct', 'run')]} | "
                 f"{total[('proxy_correct', 'axes')]} |")
    return "\n".join(lines) + "\n"


def native_markdown(table: pd.DataFrame) -> str:
    """Per field folder, periodic photos and those each pick reads within 5%; then summed."""
    prepare = validated_config()["prepare"]
    lines = [f"Periodic photos whose native period (centred {prepare['period_window']} px, {prepare['period_field']}, "
             "as `prepare` reads it) lies within 5% of "
             "the truth as seen, with the peak of most power times frequency (`weighted`) and that peak among those "
             "along the yarn axes (`axes`).", "", "| field | periodic | weighted | axes |", "|---|---|---|---|"]
    rows = [*((f"`{r['set']}`", r) for _, r in table.iterrows()), ("all", table[["periodic", "weighted", "axes"]].sum())]
    lines += [f"| {name} | {r['periodic']} | {r['weighted']} | {r['axes']} |" for name, r in rows]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", nargs=3, action="append", metavar=("RUN", "AXES_RUN", "TRUTH"))
    parser.add_argument("--native", nargs="+", metavar="FIELD", help="field folders read natively, without runs")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--name")
    args = parser.parse_args()
    if bool(args.set) == bool(args.native):
        parser.error("give either --set (repeated) or --native")
    if args.native:
        table = pd.DataFrame([native_rows(ROOT / field) for field in args.native])
        publish(args.out, args.name or "period_axes_native", table, native_markdown(table))
        return
    rows = [row for run, axes, truth in args.set for row in set_rows((ROOT / run, ROOT / axes), ROOT / truth)]
    table = pd.DataFrame(rows)
    publish(args.out, args.name or "period_axes", table, markdown(table))


if __name__ == "__main__":
    main()
