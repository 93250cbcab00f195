"""Benchmark: generic texture descriptors of the photo beside its structure descriptor.

    .venv/bin/python workflow/benchmarks/descriptor_candidates.py --set RUN FIELD [--set RUN FIELD ...] [--name descriptor_candidates]

Asks whether a more generic description of the photo would classify the weaves better than the
structure descriptor (``s_*`` and ``w_*``, :mod:`clothscope.features.structure`), and whether more
training images would. For each set (a finished run and the field folder it was rendered into, as for
``period_oracle.py``) each prepared photo's field (``features.photo_field``) is resampled to the canonical
period (:func:`clothscope.features.structure.canonical_field`) with two thread periods, ``prepare``'s and
the true one as seen, and described by four candidates, each rotation invariant and in thread periods:

- ``polar``: the power spectrum on rings, the workflow's spectrum rings since 2026-11-28
  (:func:`clothscope.features.structure.spectrum_rings`: log share of the power, ring maximum over ring mean,
  and magnitudes of angular harmonics over the ring mean);
- ``multi_lbp``: uniform LBP histograms (scikit-image) at :data:`LBP_SCALES` (1/8 to 3/4 of a period);
- ``acf``: the autocorrelation on :data:`ACF_RINGS` rings (mean, maximum, minimum and angular harmonics
  :data:`ACF_HARMONICS`);
- ``glcm``: grey-level co-occurrence (scikit-image, 64 levels) at :data:`GLCM_DISTANCES` pixels in eight
  directions (mean and range over direction of contrast, homogeneity and correlation).

Each is scored alone and beside the structure descriptor by LOOCV QDA with the workflow's shrinkage and
subspace, without tiles (the structure descriptor's own row is the reference). A last row scores all the
sets given as one pool: the same images with more training images per class. Writes
``results/bench/<name>.{csv,md}``.
"""
from __future__ import annotations

import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
from harness import ROOT, publish, validated_config
from period_oracle import accepted_photos, set_parser, true_period
from skimage.feature import graycomatrix, graycoprops, local_binary_pattern

from clothscope.classify.feature_sets import group_columns
from clothscope.classify.loocv import loocv
from clothscope.features.structure import (
    CANONICAL_PERIOD,
    StructureSettings,
    half_circle,
    spectrum_rings,
    structure_features,
    weave_rings,
)

#: (neighbours, radius in canonical pixels) of ``multi_lbp``
LBP_SCALES = ((8, 1), (8, 2), (16, 4), (16, 6))
#: ring radii of ``acf``, in thread periods
ACF_RINGS = np.arange(0.5, 3.01, 0.25)
#: angular harmonics of ``acf`` (point symmetric like the spectrum: even ones only)
ACF_HARMONICS = (2, 4, 6, 8, 12)
#: pixel offsets of ``glcm`` on the canonical field
GLCM_DISTANCES = (1, 2, 4, 6, 8, 12, 16)
#: the thread periods compared
PERIODS = ("prepare", "truth")


def _square(canonical: np.ndarray) -> np.ndarray:
    side = min(canonical.shape)
    square = canonical[:side, :side]
    return square - square.mean()


def polar(canonical: np.ndarray) -> dict[str, float]:
    """The workflow's spectrum rings (:func:`clothscope.features.structure.spectrum_rings`), named ``polar_*``."""
    return {"polar_" + name[len("p_"):]: value for name, value in spectrum_rings(canonical).items()}


def multi_lbp(canonical: np.ndarray) -> dict[str, float]:
    """Uniform LBP histograms at several radii of the canonical field."""
    out = {}
    for neighbours, radius in LBP_SCALES:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # float input: ties are what the comparison says they are
            codes = local_binary_pattern(canonical, neighbours, radius, method="uniform").astype(int)
        counts = np.bincount(codes.ravel(), minlength=neighbours + 2)
        out |= {f"multi_lbp_{neighbours}_{radius}_{k}": float(c / counts.sum()) for k, c in enumerate(counts)}
    return out


def acf(canonical: np.ndarray) -> dict[str, float]:
    """Normalised autocorrelation (zero padded) on rings in thread periods."""
    field = _square(canonical)
    side = field.shape[0]
    spectrum = np.fft.fft2(field, s=(2 * side, 2 * side))
    correlation = np.fft.fftshift(np.real(np.fft.ifft2(np.abs(spectrum) ** 2)))
    correlation /= correlation[side, side] + 1e-30
    out = {}
    for k, periods in enumerate(ACF_RINGS):
        ring = half_circle(correlation, periods * CANONICAL_PERIOD)
        out |= {f"acf_mean_{k}": float(ring.mean()), f"acf_max_{k}": float(ring.max()), f"acf_min_{k}": float(ring.min())}
        harmonics = np.abs(np.fft.rfft(ring)) / len(ring)
        out |= {f"acf_h{h}_{k}": float(harmonics[h // 2]) for h in ACF_HARMONICS}
    return out


def glcm(canonical: np.ndarray) -> dict[str, float]:
    """Co-occurrence statistics of the canonical field quantised to 64 levels (+-2 standard deviations)."""
    levels = np.clip((canonical - canonical.mean()) / (canonical.std() + 1e-12) * 16 + 32, 0, 63).astype(np.uint8)
    matrix = graycomatrix(levels, GLCM_DISTANCES, np.radians(np.arange(8) * 22.5), levels=64, symmetric=True, normed=True)
    out = {}
    for prop in ("contrast", "homogeneity", "correlation"):
        values = graycoprops(matrix, prop)
        for distance, row in zip(GLCM_DISTANCES, values):
            out[f"glcm_{prop}_{distance}_mean"] = float(row.mean())
            out[f"glcm_{prop}_{distance}_range"] = float(row.max() - row.min())
    return out


CANDIDATES: dict[str, Callable[[np.ndarray], dict[str, float]]] = {
    "polar": polar, "multi_lbp": multi_lbp, "acf": acf, "glcm": glcm}
#: the column sets scored, in the order reported
SCORED = ("structure", *CANDIDATES, *(f"structure+{name}" for name in CANDIDATES))


def set_rows(run: Path, field: Path, features: dict) -> pd.DataFrame:
    """Per image and period: the structure descriptor's and the candidates' columns."""
    lattice = StructureSettings(**features["structure"])
    rows = []
    for photo, fabric_class, described, scale in accepted_photos(run, field, features["photo_field"]):
        prepared = scale.get("working_period_px")
        for period_name, period in (("prepare", prepared), ("truth", true_period(photo, scale) or prepared)):
            columns, diagnostics = structure_features(described, lattice, period)
            row = {"run": str(run.relative_to(ROOT)), "period": period_name, "image_id": photo.stem,
                   "fabric_class": fabric_class} | columns | weave_rings(diagnostics["canonical"])
            for describe in CANDIDATES.values():
                row |= describe(diagnostics["canonical"])
            rows.append(row)
    return pd.DataFrame(rows)


def scored_columns(name: str, columns: pd.Index) -> list[str]:
    """The columns of one of :data:`SCORED` (``structure`` is the workflow's group, with the weave rings)."""
    picked = []
    for part in name.split("+"):
        picked += group_columns("structure", columns) if part == "structure" else [c for c in columns if c.startswith(part + "_")]
    return picked


def scores(table: pd.DataFrame, label: str, config: dict) -> list[dict]:
    """Images right per period and column set of ``table``'s images, as one LOOCV."""
    out = []
    for period in PERIODS:
        images = table[table["period"] == period].reset_index(drop=True)
        for name in SCORED:
            result = loocv(images, scored_columns(name, images.columns), reg=config["classify"]["reg"],
                           subspace=config["classify"]["subspace"])
            out.append({"run": label, "period": period, "columns": name, "correct": result.correct, "n": result.n})
    return out


def summary(table: pd.DataFrame) -> str:
    """Markdown: one table per period, a row per set, then their sum and the pool."""
    lines = ["LOOCV QDA (the workflow's shrinkage and subspace, no tiles) of the photo's structure descriptor "
             "(`s_*`, `w_*`) and of four generic descriptors of the same canonical field, alone and beside it: "
             "images right of each set, with the thread period `prepare` read and with the true one. `all` sums "
             "the sets; `pooled` is one LOOCV over all their images together (more training images per class).", ""]
    for period in PERIODS:
        wide = table[table["period"] == period].pivot(index="run", columns="columns", values="correct")[list(SCORED)]
        n = table[table["period"] == period].groupby("run")["n"].first()
        sets = [run for run in dict.fromkeys(table["run"]) if run != "pooled"]
        rows = [(f"`{run}`", n[run], wide.loc[run]) for run in sets]
        rows += [("all", n[sets].sum(), wide.loc[sets].sum()), ("pooled", n["pooled"], wide.loc["pooled"])]
        lines += [f"Thread period: {period}.", "", "| run | images | " + " | ".join(SCORED) + " |",
                  "|---|---|" + "---|" * len(SCORED)]
        lines += [f"| {label} | {int(count)} | " + " | ".join(str(int(row[c])) for c in SCORED) + " |"
                  for label, count, row in rows]
        lines.append("")
    return "\n".join(lines)


def main() -> None:
    args = set_parser(__doc__.splitlines()[0], "descriptor_candidates").parse_args()
    config = validated_config()
    tables = [set_rows(run.resolve(), field.resolve(), config["features"]) for run, field in args.set]
    out = [row for table in tables for row in scores(table, table["run"].iloc[0], config)]
    pooled = pd.concat(tables, ignore_index=True)
    pooled["image_id"] = pooled["run"] + "/" + pooled["image_id"]
    out += scores(pooled, "pooled", config)
    table = pd.DataFrame(out)
    publish(args.out, args.name, table, summary(table))


if __name__ == "__main__":
    main()
