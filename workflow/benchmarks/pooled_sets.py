"""Benchmark: LOOCV of every feature set on the design set, the held-out set, and both pooled.

With six images per class, each LOOCV fold leaves QDA five training images per
class. Pooling the design set with the held-out set (``snakemake holdout_set``,
rendered from another seed) gives eleven. The report scores every feature set of
``results/reports/feature_sets.md`` on each set alone and on the pool, with the
workflow's classifier settings, so it shows how much of a set's shortfall comes
from the size of the training set rather than from the features.

    .venv/bin/python workflow/benchmarks/pooled_sets.py [--design results] [--holdout results/holdout/run] [--name pooled_sets]

Writes ``results/bench/<name>.{csv,md}``. Needs both folders'
``features/{fitted,photo,truth}/table.parquet``. Takes about 8 minutes on 2 cores.
Any two runs of the same classes can be pooled, the three-weave field sets for example.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
from harness import ROOT, publish, validated_config

from clothscope.classify.feature_sets import compare_feature_sets

SOURCES = ("fitted", "photo", "truth")
#: prefix of the held-out set's image ids in the pool (both sets use the same ids)
HOLDOUT_PREFIX = "holdout:"


def read_tables(results: Path) -> dict[str, pd.DataFrame]:
    """Each source's feature table of one results folder."""
    paths = {source: results / "features" / source / "table.parquet" for source in SOURCES}
    missing = [str(path) for path in paths.values() if not path.is_file()]
    if missing:
        raise SystemExit(f"pooled_sets: error: {', '.join(missing)} not found (run the workflow on that set first)")
    return {source: pd.read_parquet(path) for source, path in paths.items()}


def pooled(design: dict[str, pd.DataFrame], holdout: dict[str, pd.DataFrame]) -> dict[str, pd.DataFrame]:
    """Both sets' tables stacked per source, the held-out ids prefixed so they stay distinct."""
    def prefixed(table: pd.DataFrame) -> pd.DataFrame:
        return table.assign(image_id=HOLDOUT_PREFIX + table["image_id"].astype(str))

    return {source: pd.concat([design[source], prefixed(holdout[source])], ignore_index=True) for source in SOURCES}


def training_per_class(tables: dict[str, pd.DataFrame]) -> int:
    """Training images per class of a LOOCV fold on these tables: the smallest class's labelled images less one."""
    labels = tables["fitted"]["fabric_class"].astype(str)
    return int(labels[labels != ""].value_counts().min()) - 1


def summary(table: pd.DataFrame, design: Path, holdout: Path, per_class: dict[str, int]) -> str:
    """The Markdown report: one row per feature set, one column per set of images."""
    wide = table.pivot(index="feature_set", columns="images", values="cell").reindex(table["feature_set"].unique())
    return ("# Feature sets on the design set, the held-out set and both pooled\n\n"
            f"LOOCV QDA with the workflow's classifier settings, whole images (no tiles). Design: `{design.relative_to(ROOT)}`; "
            f"held-out: `{holdout.relative_to(ROOT)}`. Alone, each fold trains on {per_class['design']} and "
            f"{per_class['held-out']} images per class (the smallest class); pooled, on {per_class['pooled']}. "
            "Cells: correct / images (accuracy, 95% Wilson interval).\n\n"
            + wide[["design", "held-out", "pooled"]].to_markdown() + "\n")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--design", type=Path, default=ROOT / "results")
    parser.add_argument("--holdout", type=Path, default=ROOT / "results" / "holdout" / "run")
    parser.add_argument("--name", default="pooled_sets", help="report name under results/bench/")
    args = parser.parse_args()
    design, holdout = args.design.resolve(), args.holdout.resolve()
    classify = validated_config()["classify"]
    sets = {"design": read_tables(design), "held-out": read_tables(holdout)}
    sets["pooled"] = pooled(sets["design"], sets["held-out"])
    rows = []
    for name, tables in sets.items():
        report = compare_feature_sets(tables, classify["reg"], classify["subspace"])
        for row in report[report["status"] == "ok"].itertuples():
            rows.append({"images": name, "feature_set": row.feature_set, "correct": int(row.correct), "n": int(row.n),
                         "accuracy": float(row.accuracy),
                         "cell": f"{row.correct}/{row.n} ({100 * row.accuracy:.1f}%, "
                                 f"{100 * row.wilson_low:.0f}-{100 * row.wilson_high:.0f}%)"})
        print(f"{name}: scored", flush=True)
    table = pd.DataFrame(rows)
    per_class = {name: training_per_class(tables) for name, tables in sets.items()}
    publish(ROOT / "results" / "bench", args.name, table.drop(columns="cell"), summary(table, design, holdout, per_class),
            float_format="%.4f")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
