"""Benchmark: the thread period from one lattice peak pick (``prepare.period_peak``, such as ``axes``) against another.

    .venv/bin/python workflow/benchmarks/period_axes.py --set RUN CANDIDATE_RUN TRUTH [--set ...] [--candidate axes]
        [--name period_axes]
    .venv/bin/python workflow/benchmarks/period_axes.py --native FIELD [FIELD ...] [--peaks weighted axes]
        [--name period_axes_native]

Each set is a run whose photos ``prepare`` read with one peak pick (``RUN``), the same photos prepared again with
the candidate pick (``CANDIDATE_RUN``, named by ``--candidate``; ``RUN`` prepared for example with
``config/overlays/period_weighted.yaml``) and the folder of their truth records
(``TRUTH/<class>/<id>.*`` beside ``<id>.truth.json``). Per set and run:

- the periodic photos whose recorded native period (``scale.native_period_px`` of ``prepared/<id>/status.json``)
  lies within 5% of the truth as seen in the window it was read on (the nominal period times
  :func:`clothscope.evaluate.accuracy.window_seen_scale` over ``prepare.period_window``; the closer of the thread
  and course periods);
- the classifier of record's proxy on the run's photo tables: LOOCV with the column set chosen inside each fold among
  the photo's sets, each image scored as the config's ``classify.test_tiles`` says (``held_out_tiles.py``'s
  ``photo's sets``).

With ``--native``, no run is needed: each periodic photo of each field folder is decoded and its native period read
with each pick of ``--peaks``, as ``prepare`` would (the config's ``prepare.period_window`` and
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
from clothscope.evaluate.accuracy import window_seen_scale
from clothscope.features.structure import StructureSettings
from clothscope.prepare.image import PERIOD_PEAKS, STATUS_FILE, lattice_period, native_lattice

#: the two runs of a set, in the order reported
RUNS = ("run", "candidate")


def truth_records(truth: Path) -> dict[str, dict]:
    """Truth record of each periodic photo under ``truth``, by image id."""
    records = {}
    for path in sorted(truth.glob("*/*.truth.json")):
        record = json.loads(path.read_text(encoding="utf-8"))
        if record.get("periodic"):
            records[path.name.removesuffix(".truth.json")] = record
    return records


#: a period read at least this many times the truth counts as too long
TOO_LONG = 1.3


def seen_ratio(measured: float | None, record: dict, window: int) -> float | None:
    """A native period read on the centred ``window`` over the truth as seen there (the closer of the thread and
    course periods); None without one."""
    seen = window_seen_scale(record, window)
    return period_ratio(measured, [p * seen for p in (record.get("thread_period_px"), record.get("course_period_px")) if p])


def is_within(measured: float | None, record: dict, window: int) -> bool:
    """Whether a native period read on ``window`` lies within :data:`TOLERANCE` of the truth as seen (:func:`seen_ratio`)."""
    ratio = seen_ratio(measured, record, window)
    return ratio is not None and abs(ratio - 1) <= TOLERANCE


def recorded_ratios(run: Path, records: dict[str, dict], window: int) -> list[float | None]:
    """Per periodic photo, the period ``prepare`` recorded in ``run`` over the truth as seen (None: none recorded).

    The period was read on the status's ``settings.period_window``, or ``window`` where the status does not say.
    """
    ratios = []
    for image_id, record in records.items():
        path = run / "prepared" / image_id / STATUS_FILE
        status = json.loads(path.read_text(encoding="utf-8")) if path.is_file() else {}
        read_on = (status.get("settings") or {}).get("period_window", window)
        ratios.append(seen_ratio((status.get("scale") or {}).get("native_period_px"), record, read_on))
    return ratios


def periods_within(ratios: list[float | None]) -> int:
    """Periods (:func:`recorded_ratios`) within :data:`TOLERANCE` of the truth."""
    return sum(r is not None and abs(r - 1) <= TOLERANCE for r in ratios)


def periods_too_long(ratios: list[float | None]) -> int:
    """Periods (:func:`recorded_ratios`) at least :data:`TOO_LONG` times the truth."""
    return sum(r is not None and r >= TOO_LONG for r in ratios)


def native_rows(field: Path, peaks: list[str]) -> dict:
    """Periodic photos of a field folder, and those whose native period each pick reads within 5% of the truth."""
    config = validated_config()
    lattice, prepare = StructureSettings(**config["features"]["structure"]), config["prepare"]
    records = truth_records(field)
    row = {"set": shown(field), "periodic": 0, **{peak: 0 for peak in peaks}}
    for path in sorted(field.glob("*/*.jpg")):
        record = records.get(path.stem)
        if record is None:  # not periodic
            continue
        native = native_lattice(decode_image(path, *DECODE).rgb, prepare["period_window"], lattice, prepare["period_field"])
        row["periodic"] += 1
        for peak in peaks:
            row[peak] += is_within(lattice_period(native, peak), record, prepare["period_window"])
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
    window = validated_config()["prepare"]["period_window"]
    rows = []
    for label, run in zip(RUNS, runs):
        correct, n = proxy_correct(run, settings)
        ratios = recorded_ratios(run, records, window)
        rows.append({"set": shown(runs[0]), "run": label, "folder": shown(run), "periodic": len(records),
                     "period_within_5pct": periods_within(ratios),
                     "period_too_long": periods_too_long(ratios), "proxy_correct": correct, "images": n})
    return rows


def markdown(table: pd.DataFrame, candidate: str) -> str:
    """Per set, both runs' periods within 5% and read too long, and proxy images right; then summed."""
    values = ["period_within_5pct", "period_too_long", "proxy_correct"]
    lines = ["Periodic photos whose `prepare` period lies within 5% of the truth as seen in the window it was read on, "
             "or is read at least "
             f"{TOO_LONG:g} times too long, and images right by the "
             "classifier of record's proxy (the photo's sets chosen inside each fold, scored as `classify.test_tiles` "
             f"says), with the run's period pick and with `{candidate}`.", "",
             f"| set | periodic | within 5%, run | within 5%, {candidate} | too long, run | too long, {candidate} | "
             f"images | proxy, run | proxy, {candidate} |", "|---|---|---|---|---|---|---|---|---|"]
    wide = table.pivot(index="set", columns="run", values=values)
    first = table.groupby("set")[["periodic", "images"]].first()
    sets = list(dict.fromkeys(table["set"]))
    rows = [*((f"`{name}`", wide.loc[name], first.loc[name]) for name in sets),
            ("all", wide.loc[sets].sum(), first.loc[sets].sum())]
    for name, w, f in rows:
        pairs = [f"{w[(value, 'run')]} | {w[(value, 'candidate')]}" for value in values]
        lines.append(f"| {name} | {f['periodic']} | {pairs[0]} | {pairs[1]} | {f['images']} | {pairs[2]} |")
    return "\n".join(lines) + "\n"


def native_markdown(table: pd.DataFrame, peaks: list[str]) -> str:
    """Per field folder, periodic photos and those each pick reads within 5%; then summed."""
    prepare = validated_config()["prepare"]
    lines = [f"Periodic photos whose native period (centred {prepare['period_window']} px, {prepare['period_field']}, "
             "as `prepare` reads it) lies within 5% of the truth as seen in that window, with each lattice peak pick "
             "(`prepare.period_peak`; `weighted`: the peak of most power times frequency, `axes`: that peak among those "
             "along the yarn axes, `axes_harmonic`: that, with a (1, 1) harmonic stepped down to the threads where the "
             "photo shows no yarn axes, `axes_fundamental`: that, with a 2nd to 4th harmonic of the threads stepped down to "
             "them where the photo shows no yarn axes).", "", "| field | periodic | " + " | ".join(f"`{p}`" for p in peaks) + " |",
             "|---|---|" + "---|" * len(peaks)]
    rows = [*((f"`{r['set']}`", r) for _, r in table.iterrows()), ("all", table[["periodic", *peaks]].sum())]
    lines += [f"| {name} | {r['periodic']} | " + " | ".join(str(r[p]) for p in peaks) + " |" for name, r in rows]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", nargs=3, action="append", metavar=("RUN", "CANDIDATE_RUN", "TRUTH"))
    parser.add_argument("--candidate", default="axes", help="the pick CANDIDATE_RUN was prepared with (its label)")
    parser.add_argument("--native", nargs="+", metavar="FIELD", help="field folders read natively, without runs")
    parser.add_argument("--peaks", nargs="+", default=["weighted", "axes"], choices=PERIOD_PEAKS,
                        help="the picks compared with --native")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--name")
    args = parser.parse_args()
    if bool(args.set) == bool(args.native):
        parser.error("give either --set (repeated) or --native")
    if args.native:
        table = pd.DataFrame([native_rows(ROOT / field, args.peaks) for field in args.native])
        publish(args.out, args.name or "period_axes_native", table, native_markdown(table, args.peaks))
        return
    rows = [row for run, candidate, truth in args.set for row in set_rows((ROOT / run, ROOT / candidate), ROOT / truth)]
    table = pd.DataFrame(rows)
    publish(args.out, args.name or "period_axes", table, markdown(table, args.candidate))


if __name__ == "__main__":
    main()
