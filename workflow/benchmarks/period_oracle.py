"""Benchmark: what a perfect thread period would buy the photo's structure descriptor.

    .venv/bin/python workflow/benchmarks/period_oracle.py --set RUN FIELD [--set RUN FIELD ...] [--name period_oracle]

The structure descriptor describes a map in units of its thread period (``f0``), so a period read
wrong moves every column. This asks how much of the classifier's errors that explains. For each set
(a finished run and the field folder it was rendered into, ``<field>/<class>/<id>.jpg`` with truth
records) the photo's structure descriptor (``photo_structure``, with the run's tiles, as the classifier
of record reads it) is recomputed on each prepared photo with the thread period taken four ways:

- ``own``: the map's own lattice peaks (``features.period_source: field``);
- ``prepare``: the period ``prepare`` read at native resolution (``scale.working_period_px``);
- ``stepped``: that period with a (1, 1) harmonic stepped down to the threads
  (``period_harmonic.py``'s candidate at its ``beta``, rejected in docs/design.md);
- ``truth``: the true period as seen (:func:`clothscope.evaluate.accuracy.seen_scale`), in working pixels.

Only ``f0`` changes: the prepared photo and its crop stay those of the run (a crop made with the true
period would differ). Photos without a true period keep ``prepare``'s. Scores are LOOCV QDA with the
workflow's shrinkage and subspace; no sign test or column choice is involved. Writes
``results/bench/<name>.{csv,md}``.
"""
from __future__ import annotations

import argparse
import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pandas as pd
from field_set import DECODE
from harness import ROOT, publish, validated_config
from period_harmonic import BETA, TOLERANCE, threads_below

from clothscope.classify.feature_sets import group_columns
from clothscope.classify.loocv import loocv
from clothscope.core.imageio import decode_image
from clothscope.core.truth import truth_paths
from clothscope.evaluate.accuracy import seen_scale
from clothscope.features.sources import load_photo
from clothscope.features.structure import StructureSettings, texture_columns
from clothscope.features.table import tile_rows, tile_settings
from clothscope.prepare.image import STATUS_FILE, native_lattice, period_peak_radius

#: the thread periods compared, in the order reported
PERIODS = ("own", "prepare", "stepped", "truth")


def true_period(photo: Path, scale: dict) -> float | None:
    """The true thread period as seen, in the prepared map's pixels (None: the cloth has no period)."""
    per_working = float(scale.get("native_px_per_working_px") or 1.0)
    truth = json.loads(truth_paths(photo)["json"].read_text(encoding="utf-8"))
    return truth["thread_period_px"] * seen_scale(truth) / per_working if truth["periodic"] else None


def periods_of(photo: Path, scale: dict, lattice: StructureSettings) -> dict[str, float | None]:
    """The working-pixel thread period of each of :data:`PERIODS` for one photo (None: the map's own)."""
    prepared = scale.get("working_period_px")
    true = true_period(photo, scale)
    stepped = prepared
    if prepared:
        native = native_lattice(decode_image(photo, *DECODE).rgb, 1024, lattice)
        s, found = native.spectrum, native.found
        if found.found:
            stepped = prepared * period_peak_radius(s, found.peaks, "weighted") / threads_below(s, found.peaks, BETA)
    return {"own": None, "prepare": prepared, "stepped": stepped, "truth": true}


def accepted_photos(run: Path, field: Path, photo_field: str) -> Iterator[tuple[Path, str, np.ndarray, dict]]:
    """Each photo of ``field`` that the run's ``prepare`` accepted: its path, class, described field
    (``features.photo_field`` of the prepared photo) and ``scale`` record."""
    for photo in sorted(field.glob("*/*.jpg")):
        prepared = run / "prepared" / photo.stem
        status = json.loads((prepared / STATUS_FILE).read_text(encoding="utf-8"))
        if status.get("status") == "accepted":
            yield photo, photo.parent.name, load_photo(prepared, photo_field).field, status.get("scale") or {}


def set_rows(run: Path, field: Path, features: dict) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per image and period: the descriptor's columns (``period`` names which), and the tiles' rows alike."""
    lattice = StructureSettings(**features["structure"])
    tiles = tile_settings(features["tiles"])
    rows, tile_table = [], []
    for photo, fabric_class, described, scale in accepted_photos(run, field, features["photo_field"]):
        image_id = photo.stem
        periods = periods_of(photo, scale, lattice)
        true = periods["truth"]
        periods["truth"] = true or periods["prepare"]
        ratio = (periods["prepare"] or 0.0) / true if true else None  # 0: prepare found no lattice
        for name, period in periods.items():
            label = {"period": name, "image_id": image_id, "fabric_class": fabric_class, "period_px": period,
                     "prepare_over_truth": ratio}
            rows.append(label | texture_columns(described, lattice, period))
            tile_table += [label | row for row in tile_rows(image_id, described, lattice, tiles, period)]
    return pd.DataFrame(rows), pd.DataFrame(tile_table)


def prepare_errors(table: pd.DataFrame) -> dict[str, int]:
    """Photos whose ``prepare`` period is off the truth by more than :data:`TOLERANCE`, and of them those read at
    about 1/sqrt(2) of it (the lattice's (1, 1) harmonic)."""
    ratios = table.loc[table["period"] == "prepare", "prepare_over_truth"].dropna()
    wrong = (ratios - 1).abs() > TOLERANCE
    return {"periodic": len(ratios), "prepare_wrong": int(wrong.sum()),
            "harmonic": int((wrong & ((ratios * 2 ** 0.5 - 1).abs() <= TOLERANCE)).sum())}


def scores(run: Path, field: Path, config: dict) -> list[dict]:
    """Images right per period of one set (LOOCV of the photo's structure descriptor with its tiles)."""
    table, tiles = set_rows(run, field, config["features"])
    errors = prepare_errors(table)
    out = []
    for name in PERIODS:
        images = table[table["period"] == name].reset_index(drop=True)
        own_tiles = tiles[tiles["period"] == name].reset_index(drop=True) if not tiles.empty else None
        result = loocv(images, group_columns("structure", images.columns), reg=config["classify"]["reg"],
                       subspace=config["classify"]["subspace"], tiles=own_tiles)
        out.append({"run": str(run.relative_to(ROOT)), "period": name, "correct": result.correct, "n": result.n} | errors)
    return out


def summary(table: pd.DataFrame) -> str:
    """Markdown: images right per set and period, and summed."""
    wide = table.pivot(index="run", columns="period", values="correct")[list(PERIODS)]
    per_run = table.groupby("run")[["n", "periodic", "prepare_wrong", "harmonic"]].first()
    wide = wide.join(per_run).loc[list(dict.fromkeys(table["run"]))]
    columns = [*PERIODS, "n", "periodic", "prepare_wrong", "harmonic"]
    lines = ["LOOCV QDA of the photo's structure descriptor (`photo_structure`, with tiles) with the thread period "
             "taken from the map's own peaks, from `prepare`, from `prepare` with a (1, 1) harmonic stepped down, and "
             "from the truth as seen: images right of each set. Only the descriptor's period changes, not the crop. "
             f"The last column counts the periodic photos whose `prepare` period is more than {TOLERANCE:.0%} off the "
             "truth, and of those how many it read at about 1/sqrt(2) of the truth (the lattice's (1, 1) harmonic).", "",
             "| run | images | " + " | ".join(PERIODS) + " | `prepare` period off (at 1/sqrt(2)) |",
             "|---|---|" + "---|" * (len(PERIODS) + 1)]
    rows = [*wide[columns].iterrows(), ("all", wide[columns].sum())]
    lines += [f"| {run if run == 'all' else f'`{run}`'} | {int(row['n'])} | " + " | ".join(str(int(row[p])) for p in PERIODS)
              + f" | {int(row['prepare_wrong'])} of {int(row['periodic'])} ({int(row['harmonic'])}) |" for run, row in rows]
    return "\n".join(lines + [""])


def set_parser(description: str, name: str) -> argparse.ArgumentParser:
    """The command line of a benchmark over field sets: ``--set RUN FIELD`` (repeated), ``--out`` and ``--name``."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--set", nargs=2, action="append", type=Path, required=True, metavar=("RUN", "FIELD"),
                        help="a finished run and the field folder its photos came from")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--name", default=name, help="report name (<out>/<name>.{csv,md})")
    return parser


def main() -> None:
    args = set_parser(__doc__.splitlines()[0], "period_oracle").parse_args()
    config = validated_config()
    table = pd.DataFrame([row for run, field in args.set for row in scores(run.resolve(), field.resolve(), config)])
    publish(args.out, args.name, table, summary(table))


if __name__ == "__main__":
    main()
