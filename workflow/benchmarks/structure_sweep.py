"""Benchmark: LOOCV accuracy of the structure descriptor over its settings, on the design set and the held-out set.

Recomputes the ``s_*`` columns of every image's fitted relief (and the
photo's luminance) for each cell of a grid of
:class:`clothscope.features.structure.StructureSettings`, and scores each feature set
by the workflow's LOOCV QDA. The best cell of a grid chosen by looking at
these scores is **optimistic** (the settings saw the images they are scored
on); the report marks it, and gives the same cells on a second results folder
(the held-out set, rendered from ``synthesize.holdout_seed``) that no design
choice looked at.

    .venv/bin/python workflow/benchmarks/structure_sweep.py [--design results] [--holdout results/holdout/run]

Writes ``results/reports/structure_sweep.{csv,md}``. Needs both folders'
``features/{fitted,photo}/table.parquet`` and the maps behind them.
"""
from __future__ import annotations

import argparse
import warnings
from functools import partial
from pathlib import Path

import pandas as pd
from harness import ROOT, publish, validated_config

from clothscope.classify.feature_sets import FEATURE_SETS, common_images, score_feature_set
from clothscope.features.sources import load_fitted, load_photo
from clothscope.features.structure import StructureSettings, structure_features

#: cells of the sweep: border x peak threshold at the default fundamental fraction, and the other fraction at the default
CELLS = [*({"border": b, "peak_threshold": t, "fundamental_fraction": 0.3} for b in (0.0, 0.1, 0.2) for t in (5.0, 10.0)),
         {"border": 0.1, "peak_threshold": 10.0, "fundamental_fraction": 0.6}]
GRID = tuple(CELLS[0])
SETS = ("structure_fitted", "structure_brdf_fitted", "structure_photo", "fitted_plus_photo")


def load_fields(results: Path) -> dict[str, dict[str, object]]:
    """Each source's table and every usable image's field, from one results folder."""
    out = {}
    features = validated_config()["features"]
    fitted = partial(load_fitted, field=features["fitted_field"])
    photo = partial(load_photo, field=features["photo_field"])
    for source, loader, folder in (("fitted", fitted, "fit/{}/normals"), ("photo", photo, "prepared/{}")):
        table = pd.read_parquet(results / "features" / source / "table.parquet")
        fields = {}
        for image in table.loc[table["status"] == "ok", "image_id"]:
            fields[image] = loader(results / folder.format(image)).field
        out[source] = {"table": table, "fields": fields}
    return out


def with_settings(data: dict[str, dict[str, object]], settings: StructureSettings) -> dict[str, pd.DataFrame]:
    """Each source's table with its ``s_*`` columns recomputed under ``settings``."""
    tables = {}
    for source, entry in data.items():
        table = entry["table"].copy()
        for image, field in entry["fields"].items():
            features, _ = structure_features(field, settings)
            index = table.index[table["image_id"] == image][0]
            for name, value in features.items():
                table.loc[index, name] = value
        tables[source] = table
    return tables


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--design", default="results", help="results folder of the design set")
    parser.add_argument("--holdout", default="results/holdout/run", help="results folder of the held-out set")
    args = parser.parse_args()
    warnings.filterwarnings("ignore")
    folders = {"design": ROOT / args.design, "holdout": ROOT / args.holdout}
    data = {name: load_fields(folder) for name, folder in folders.items() if (folder / "features" / "fitted").is_dir()}
    rows = []
    for cell in CELLS:
        settings = StructureSettings(**{**validated_config()["features"]["structure"], **cell})
        for name, entry in data.items():
            tables = with_settings(entry, settings)
            images = common_images(tables)
            for feature_set in (s for s in FEATURE_SETS if s.name in SETS):
                scored = score_feature_set(feature_set, tables, images, "auto", "none")
                rows.append({"set": name, **cell, "feature_set": feature_set.name, "correct": int(scored["correct"]),
                             "n": int(scored["n"]), "accuracy": float(scored["accuracy"])})
    table = pd.DataFrame(rows)
    lines = ["# Structure descriptor settings: LOOCV accuracy on the design and held-out sets", "",
             "Each row: one cell of the grid, every feature set's LOOCV accuracy (QDA, same images per set). The cell "
             "marked *optimistic* is the best on the design set for structure_brdf_fitted: it was chosen by looking at "
             "those scores, so its design-set figure overstates what new images will see; the held-out column did not "
             "take part in any choice.", ""]
    wide = table.pivot_table(index=[*GRID, "feature_set"], columns="set", values="accuracy").reset_index()
    key = wide[wide["feature_set"] == "structure_brdf_fitted"]
    best = key.loc[key["design"].idxmax()] if "design" in key else None
    lines += ["| border | peak threshold | fundamental fraction | feature set | design | held-out | |", "|---|---|---|---|---|---|---|"]
    for _, r in wide.iterrows():
        mark = "optimistic" if best is not None and r["feature_set"] == "structure_brdf_fitted" and all(
            r[k] == best[k] for k in GRID) else ""
        lines.append(f"| {r['border']} | {r['peak_threshold']} | {r['fundamental_fraction']} | {r['feature_set']} | "
                     f"{100 * r.get('design', float('nan')):.1f}% | {100 * r.get('holdout', float('nan')):.1f}% | {mark} |")
    publish(ROOT / "results" / "reports", "structure_sweep", table, "\n".join(lines) + "\n", float_format="%.4f")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
