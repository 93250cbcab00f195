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
with each pick of ``--peaks``, as ``prepare`` would (the config's ``prepare.period_window``, on the config's
``prepare.period_field`` or on each field of ``--fields``); the report then gives periods
within 5% only (how the pick's settings were chosen, on sets no confirmation used). ``--sheets`` adds photos without
truth (sample sheets, such as the real sets'): per sheet, the photos whose periods on the first two ``--fields``
differ by more than 5%. Writes ``results/bench/<name>.{csv,md}``.

    .venv/bin/python workflow/benchmarks/period_axes.py --native FIELD [FIELD ...] --peaks axes_fundamental
        --fields shading luminance [--sheets SHEET ...] [--name period_fields]
"""
from __future__ import annotations

import argparse
import json
from functools import cache
from pathlib import Path

import pandas as pd
from class_subsets import classify_config
from field_set import DECODE, TOLERANCE, period_ratio
from harness import ROOT, publish, record_loocv, shown, validated_config
from held_out_tiles import scored_lists

from clothscope.core.config import config_schema
from clothscope.core.imageio import ImageRejected, decode_image
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


def pick_columns(peaks: list[str], fields: list[str]) -> list[str]:
    """Report columns: the picks, each prefixed with its analysis field when several fields are compared."""
    return list(peaks) if len(fields) == 1 else [f"{field} {peak}" for field in fields for peak in peaks]


@cache
def reading_settings() -> tuple[StructureSettings, int]:
    """The config's lattice peak test and ``prepare.period_window``."""
    config = validated_config()
    return StructureSettings(**config["features"]["structure"]), config["prepare"]["period_window"]


def native_periods(path: Path, peaks: list[str], fields: list[str]) -> dict[str, float | None]:
    """A photo's native period (None: no lattice) per column of :func:`pick_columns`, read as ``prepare`` reads it."""
    lattice, window = reading_settings()
    rgb = decode_image(path, *DECODE).rgb
    periods = []
    for field in fields:  # field-major, as pick_columns orders them
        native = native_lattice(rgb, window, lattice, field)
        periods += [lattice_period(native, peak) for peak in peaks]
    return dict(zip(pick_columns(peaks, fields), periods))


def native_rows(field: Path, peaks: list[str], fields: list[str]) -> dict:
    """Periodic photos of a field folder, and those whose native period each pick reads within 5% of the truth."""
    window = reading_settings()[1]
    records = truth_records(field)
    columns = pick_columns(peaks, fields)
    row = {"set": shown(field), "periodic": 0, **{column: 0 for column in columns}}
    for path in sorted(field.glob("*/*.jpg")):
        record = records.get(path.stem)
        if record is None:  # not periodic
            continue
        row["periodic"] += 1
        for column, period in native_periods(path, peaks, fields).items():
            row[column] += is_within(period, record, window)
    return row


def sheet_row(sheet: Path, peak: str, fields: list[str]) -> dict:
    """Photos of a sample sheet that decode, and those whose periods on the first two ``fields`` differ by over 5%."""
    table = pd.read_csv(sheet, sep="\t")
    row = {"set": shown(sheet), "photos": 0, "differ": 0}
    for path in table["path"]:
        try:
            periods = list(native_periods(ROOT / path, [peak], fields[:2]).values())
        except ImageRejected:  # prepare would reject it too
            continue
        row["photos"] += 1
        a, b = periods
        row["differ"] += (a is None) != (b is None) or (a is not None and abs(a / b - 1) > TOLERANCE)
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


def native_markdown(table: pd.DataFrame, columns: list[str], fields: list[str], sheets: pd.DataFrame | None) -> str:
    """Per field folder, periodic photos and those each pick reads within 5%; then summed; then the sheets' photos
    whose periods on two fields differ."""
    window = reading_settings()[1]
    read_on = " and the ".join(fields)
    lines = [f"Periodic photos whose native period (centred {window} px, on the {read_on}, "
             "as `prepare` reads it) lies within 5% of the truth as seen in that window, with each lattice peak pick "
             "(`prepare.period_peak`; `weighted`: the peak of most power times frequency, `axes`: that peak among those "
             "along the yarn axes, `axes_harmonic`: that, with a (1, 1) harmonic stepped down to the threads where the "
             "photo shows no yarn axes, `axes_fundamental`: that, with a 2nd to 4th harmonic of the threads stepped down to "
             "them where the photo shows no yarn axes).", "",
             "| field | periodic | " + " | ".join(f"`{c}`" for c in columns) + " |", "|---|---|" + "---|" * len(columns)]
    rows = [*((f"`{r['set']}`", r) for _, r in table.iterrows()), ("all", table[["periodic", *columns]].sum())]
    lines += [f"| {name} | {r['periodic']} | " + " | ".join(str(r[c]) for c in columns) + " |" for name, r in rows]
    if sheets is not None and len(sheets):
        lines += ["", f"Photos without truth whose periods on the {fields[0]} and the {fields[1]} differ by more than 5% "
                  "(or only one finds a lattice):", "", "| sheet | photos | differ |", "|---|---|---|"]
        lines += [f"| `{r['set']}` | {r['photos']} | {r['differ']} |" for _, r in sheets.iterrows()]
        lines.append(f"| all | {sheets['photos'].sum()} | {sheets['differ'].sum()} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", nargs=3, action="append", metavar=("RUN", "CANDIDATE_RUN", "TRUTH"))
    parser.add_argument("--candidate", default="axes", help="the pick CANDIDATE_RUN was prepared with (its label)")
    parser.add_argument("--native", nargs="+", metavar="FIELD", help="field folders read natively, without runs")
    parser.add_argument("--peaks", nargs="+", default=["weighted", "axes"], choices=PERIOD_PEAKS,
                        help="the picks compared with --native")
    field_names = config_schema()["properties"]["prepare"]["properties"]["period_field"]["enum"]
    parser.add_argument("--fields", nargs="+", choices=field_names,
                        help="with --native: the analysis fields read (default: the config's prepare.period_field)")
    parser.add_argument("--sheets", nargs="+", metavar="SHEET",
                        help="with --native and two --fields: sample sheets of photos without truth")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--name")
    args = parser.parse_args()
    if bool(args.set) == bool(args.native):
        parser.error("give either --set (repeated) or --native")
    if args.native:
        fields = args.fields or [validated_config()["prepare"]["period_field"]]
        if args.sheets and len(fields) < 2:
            parser.error("--sheets compares two --fields")
        table = pd.DataFrame([native_rows(ROOT / field, args.peaks, fields) for field in args.native])
        sheets = pd.DataFrame([sheet_row(ROOT / sheet, args.peaks[0], fields) for sheet in args.sheets or []])
        publish(args.out, args.name or "period_axes_native", table,
                native_markdown(table, pick_columns(args.peaks, fields), fields, sheets))
        return
    rows = [row for run, candidate, truth in args.set for row in set_rows((ROOT / run, ROOT / candidate), ROOT / truth)]
    table = pd.DataFrame(rows)
    publish(args.out, args.name or "period_axes", table, markdown(table, args.candidate))


if __name__ == "__main__":
    main()
