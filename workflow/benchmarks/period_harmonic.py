"""Benchmark: ``prepare``'s native thread period, and the same with a (1, 1) harmonic stepped down to the threads.

    .venv/bin/python workflow/benchmarks/period_harmonic.py FIELD [FIELD ...] [--beta 0.3] [--name period_harmonic]

On a woven lattice whose crossings shade as round bumps (a plain weave or a twill under a ring or
coaxial light), the peak with the most power times frequency, which ``prepare`` takes
(:func:`clothscope.prepare.image.period_peak_radius`), is often the lattice's (1, 1) harmonic: the
period comes out sqrt(2) times too short. The threads' own peaks then sit at 1/sqrt(2) of its radius,
45 degrees from it. The candidate takes the strongest of those (radius within 5%, direction within
8 degrees) instead when it holds at least ``beta`` of the pick's power. The same geometry appears the
other way round on a plain weave whose checkerboard of floats is strong: there the pick is the threads
and the peaks at 1/sqrt(2) are the checkerboard's, so ``beta`` is what tells the two apart.

For every periodic image of each field folder (``<field>/<class>/<id>.jpg`` with its truth record)
the peaks are those of ``prepare``'s own lattice test on the centred 1024 px of the photo's shading
(:func:`clothscope.prepare.image.native_lattice`); the period is compared with the true one as
seen (:func:`clothscope.evaluate.accuracy.seen_scale`). Reports per folder how many periods each rule
reads within 5%, at most 0.75 times (too short) and at least 1.3 times the truth (too long). Writes
``results/bench/<name>.{csv,md}``. Measured against a rule written before scoring and rejected
(``docs/design.md``, "A (1, 1) harmonic read as the period").
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pandas as pd
from field_set import DECODE, period_ratio
from harness import ROOT, publish, validated_config

from clothscope.core.imageio import decode_image
from clothscope.core.truth import truth_paths
from clothscope.evaluate.accuracy import seen_scale
from clothscope.features.structure import Spectrum, StructureSettings, refined_radius
from clothscope.prepare.image import (
    HARMONIC_MIN_POWER,
    native_lattice,
    period_peak_index,
    period_peak_radius,
    threads_below_harmonic,
)

#: periods within this fraction of the truth count as right; at most SHORT or at least LONG times it as wrong that way
TOLERANCE, SHORT, LONG = 0.05, 0.75, 1.3
#: least power of the threads' peak over the pick's at which the candidate steps down (``--beta``)
BETA = HARMONIC_MIN_POWER


def threads_below(s: Spectrum, peaks: np.ndarray, beta: float) -> float:
    """The radius (bins) ``prepare`` picks with ``weighted``, or that of the threads' peak below it when it is their
    (1, 1) harmonic and that peak holds at least ``beta`` of its power (:func:`threads_below_harmonic`)."""
    pick = threads_below_harmonic(s, peaks, period_peak_index(s, peaks, "weighted"), beta)
    return refined_radius(s, int(peaks[pick]))


def image_row(path: Path, lattice: StructureSettings, beta: float) -> dict | None:
    """Both periods of one photo against its truth; None for a cloth without a period."""
    truth = json.loads(truth_paths(path)["json"].read_text(encoding="utf-8"))
    if not truth["periodic"]:
        return None
    seen = seen_scale(truth)
    periods = [p * seen for p in (truth["thread_period_px"], truth["course_period_px"]) if p]
    native = native_lattice(decode_image(path, *DECODE).rgb, 1024, lattice)
    side, s, found = native.side, native.spectrum, native.found
    row = {"field": str(path.parent.parent.relative_to(ROOT)), "image_id": path.stem, "fabric_class": truth["fabric_class"],
           "capture": truth["draw"]["capture"], "true_period_px": periods[0], "default_ratio": None, "stepped_ratio": None}
    if found.found:
        row["default_ratio"] = period_ratio(side / period_peak_radius(s, found.peaks, "weighted"), periods)
        row["stepped_ratio"] = period_ratio(side / threads_below(s, found.peaks, beta), periods)
    return row


def counts(ratios: pd.Series) -> tuple[int, int, int]:
    """Within the tolerance, too short and too long (a photo without a lattice is none of them)."""
    found = ratios.dropna()
    return int(((found - 1).abs() < TOLERANCE).sum()), int((found <= SHORT).sum()), int((found >= LONG).sum())


def summary(table: pd.DataFrame, beta: float) -> str:
    """Markdown: per field folder and in all, the counts of both rules."""
    lines = [f"Native thread period of `prepare` (the peak with the most power times frequency) and the same with a (1, 1) "
             f"harmonic stepped down to the threads (beta {beta:g}): periods within {TOLERANCE:.0%} of the truth as seen, "
             f"read at most {SHORT:g} times (too short) and at least {LONG:g} times (too long) the truth, of the periodic images.", "",
             "| field set | images | default: within 5% | too short | too long | stepped: within 5% | too short | too long |",
             "|---|---|---|---|---|---|---|---|"]
    groups = [*table.groupby("field", sort=False), ("all", table)]
    for name, group in groups:
        lines.append(f"| {name if name == 'all' else f'`{name}`'} | {len(group)} | "
                     + " | ".join(str(v) for v in counts(group["default_ratio"]) + counts(group["stepped_ratio"])) + " |")
    return "\n".join(lines + [""])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("fields", nargs="+", type=Path, help="field set folders (results/<name>/field)")
    parser.add_argument("--beta", type=float, default=BETA, help="least power of the threads' peak over the pick's")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--name", default="period_harmonic", help="report name (<out>/<name>.{csv,md})")
    args = parser.parse_args()
    lattice = StructureSettings(**validated_config()["features"]["structure"])
    rows = [row for field in args.fields for path in sorted(field.resolve().glob("*/*.jpg"))
            if (row := image_row(path, lattice, args.beta)) is not None]
    table = pd.DataFrame(rows)
    publish(args.out, args.name, table, summary(table, args.beta), float_format="%.4g")


if __name__ == "__main__":
    main()
