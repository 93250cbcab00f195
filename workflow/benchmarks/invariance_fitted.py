"""Benchmark: do predictions from *fitted* maps survive rotating, zooming and recolouring the photo?

For each chosen image of the default sheet (two per class by default) the
photo is transformed three ways (:data:`clothscope.evaluate.invariance.PHOTO_TRANSFORMS`):

* ``rotate30``: turned 30 degrees, the valid centre kept (181 of 256 px; the
  prepare stage resizes it to the working resolution, so it is also magnified
  by 1.41);
* ``zoom1.5``: the centre 1 / 1.5 of the photo (a camera 1.5 times closer);
* ``hue120``: every hue turned by 120 degrees (another dye).

The transformed photos are prepared, **refitted** and described by the
workflow (``--config samples=... results=<out>/run``). A prediction counts as
changed when the model trained on all *other* original images (the main run's
feature tables, with their tiles, ``features.tiles``) predicts another class
for the transformed photo than for the original. The model is the configured
classifier (``classify.reg``, ``classify.subspace`` and ``classify.test_tiles``); an ``auto`` set, and
``record`` (the classifier of record: ``classify.feature_set`` on fitted maps
with the photo beside them), choose their columns on those other images as the
``classify`` rule does; ``record_vote`` is the record with ``classify.feature_set: vote``, every set voting
(``record`` follows ``classify.prune`` too).
Needs the main run's ``fitted`` and ``photo`` feature tables.

    .venv/bin/python workflow/benchmarks/invariance_fitted.py [--images a,b|all] [--out results/bench/invariance] [--features-only]
        [--overlay config/overlays/NAME.yaml] [--prefer SET ...] [--scores-only] [--transforms rotate30,zoom1.5,hue120|refit]

``--transforms`` picks some of them, or ``refit``: the photo as it is, refitted. With
``--overlay config/overlays/fit_seed_1.yaml`` (other render samples) that counts the
predictions a refit alone changes: the benchmark's own noise, against which the
transformations' counts are read.

``--features-only`` reuses the run folder's fits and recomputes only the
feature rows (after a change to the features, not to the fit); ``--scores-only``
runs nothing and scores the run folder's feature tables as they are (after a
change to the classifier alone). ``--overlay``
runs the transformed photos with that config overlay (the main run's feature
tables, which train the models, must have been made with it too). ``--prefer SET ...`` adds rows for the record choosing one set (``auto``)
with each of those ``classify.choice.prefer`` values.

Writes ``<out>/invariance_fitted.csv`` (one row per feature set and
transformation) and ``<out>/invariance_fitted.md``.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
from class_subsets import classify_config
from harness import ROOT, publish, run_tables, snakemake, write_sheet
from record_candidates import PREFER_CHOICES

from clothscope.classify.feature_sets import (
    FEATURE_SETS,
    auto_candidates,
    classifier_candidates,
    common_images,
    joined_features,
    joined_tiles,
)
from clothscope.classify.loocv import Choice, candidates_model
from clothscope.classify.model import predict
from clothscope.core.config import schema_defaults
from clothscope.core.imageio import decode_image, linear_to_srgb, write_png
from clothscope.evaluate.invariance import PHOTO_TRANSFORMS

#: two images per class
PAIRS = ",".join(f"{c}_{d}" for c in ("broadcloth", "canvas", "satin", "chiffon", "cotton_gauze", "knit_jersey", "velvet")
                 for d in ("red", "navy"))
#: feature sets whose invariance is measured (the sources both exist for transformed photos)
SETS = ("record", "record_vote", "auto_fitted", "vote_fitted", "texture_brdf_fitted", "structure_brdf_fitted", "paper_fitted", "auto_photo",
        "lbp_photo", "structure_photo", "photo_plus_brdf")
#: the feature set standing for the classifier of record's sources (fitted maps, the photo beside them)
RECORD_SOURCES = "fitted_plus_photo"
#: the classifier of record as configured (None: ``classify.feature_set``) and voting over its candidates
RECORDS = {"record": None, "record_vote": "vote"}

#: every transformation the benchmark can apply: the workflow's three, and the photo as it is (``refit``: with another
#: ``fit.sample_seed`` it measures what a refit alone changes)
TRANSFORMS = {**PHOTO_TRANSFORMS, "refit": lambda rgb: rgb}

#: decode_image limits: the config schema's prepare defaults
DECODE = tuple(schema_defaults()["prepare"][k] for k in ("min_input_px", "max_megapixels", "clip_threshold"))


def transformed_sheet(sheet: pd.DataFrame, out: Path, transforms: list[str]) -> pd.DataFrame:
    """Write every photo of ``sheet`` under ``out/photos`` as each of ``transforms`` makes it; their sample sheet."""
    rows = []
    for _, row in sheet.iterrows():
        srgb = linear_to_srgb(decode_image(ROOT / row["path"], *DECODE).rgb)
        for name in transforms:
            path = out / "photos" / name / f"{row['image_id']}.png"
            path.parent.mkdir(parents=True, exist_ok=True)
            if not path.exists():  # the same photo again would look new to Snakemake and redo its fit
                write_png(path, TRANSFORMS[name](srgb))
            rows.append({**row.to_dict(), "image_id": f"{row['image_id']}__{name}", "path": str(path.relative_to(ROOT)),
                         "source": f"{name} of {row['image_id']}"})
    return pd.DataFrame(rows, columns=sheet.columns)


def record_how(settings: dict) -> str:
    """How the configured record combines its sets, for the report: the vote's pruning or ``auto``'s preferred set."""
    if settings["feature_set"] == "vote":
        return f"pruned at {settings['prune']:g}" if settings["prune"] else "every set voting"
    return f"preferred set `{settings['choice']['prefer']}`, or the one named"


def candidates_of(feature_set: str, columns: list[str], settings: dict) -> tuple[dict[str, list[str]], float | None]:
    """The column sets a model of ``feature_set`` chooses from (one set unless it is ``auto``, ``vote`` or ``record``),
    and, where their posteriors are averaged instead (``vote``), the level it prunes them at (``classify.prune`` for
    ``record``, 0 for ``record_vote`` and a source's vote); None where one set is used."""
    if feature_set in RECORDS:
        configured = RECORDS[feature_set] or settings["feature_set"]
        prune = settings["prune"] if feature_set == "record" else 0.0
        return classifier_candidates(configured, "fitted", columns), prune if configured == "vote" else None
    pooled = next(s for s in FEATURE_SETS if s.name == feature_set).pooled()
    if pooled is None:
        return {feature_set: columns}, None
    return auto_candidates(columns, pooled[0]), 0.0 if pooled[1] else None


def view_predictions(others: pd.DataFrame, views: pd.DataFrame, candidates: dict[str, list[str]], prune: float | None,
                     settings: dict, tiles: pd.DataFrame | None, scored_tiles: pd.DataFrame | None) -> list[str]:
    """The classes a model trained on ``others`` predicts for the rows of ``views``: the mean posterior of every
    candidate's QDA not pruned at ``prune`` (a number: a vote), or the QDA of the candidate :func:`choose_columns`
    picks (None; :func:`candidates_model`)."""
    model = candidates_model(others, candidates, settings["reg"], settings["subspace"], tiles,
                             choice=Choice.from_config(settings["choice"]), vote=prune is not None, prune=prune or 0.0)
    return list(predict(model, views, scored_tiles)["predicted_class"])


def changed_predictions(feature_set: str, originals: dict[str, pd.DataFrame], transformed: dict[str, pd.DataFrame],
                        images: list[str], settings: dict, tile_tables: dict[str, pd.DataFrame],
                        transformed_tiles: dict[str, pd.DataFrame], transforms: list[str]) -> list[dict[str, object]]:
    """One row per transformation of ``transforms``: train on all other originals (and their tiles), once per original, predict the
    original and each of its transformed photos (each with its own tiles where ``classify.test_tiles`` is ``mean``);
    count changes."""
    spec = next(s for s in FEATURE_SETS if s.name == (RECORD_SOURCES if feature_set in RECORDS else feature_set))
    tiles = joined_tiles({s: originals[s] for s in spec.sources}, tile_tables)
    scored_tiles = None if settings["test_tiles"] != "mean" else pd.concat(
        [tiles, joined_tiles({s: transformed[s] for s in spec.sources}, transformed_tiles)])
    frame, columns = joined_features(spec, originals, common_images({s: originals[s] for s in spec.sources}))
    if feature_set in RECORDS:
        columns = [c for c in frame.columns if c.split(".", 1)[0] in spec.sources]
    usable_now = set(common_images({s: transformed[s] for s in spec.sources}))
    ok = {t: [i for i in images if f"{i}__{t}" in usable_now] for t in transforms}
    t_frame, _ = joined_features(spec, transformed, [f"{i}__{t}" for t in transforms for i in ok[t]])
    candidates, prune = candidates_of(feature_set, columns, settings)
    changed, wrong = dict.fromkeys(transforms, 0), dict.fromkeys(transforms, 0)
    for original in dict.fromkeys(i for t in transforms for i in ok[t]):
        others = frame[frame["image_id"] != original]
        present = [t for t in transforms if original in ok[t]]
        views = pd.concat([frame[frame["image_id"] == original],
                           *(t_frame[t_frame["image_id"] == f"{original}__{t}"] for t in present)], ignore_index=True)
        before, *afters = view_predictions(others, views, candidates, prune, settings, tiles, scored_tiles)
        for transform, after in zip(present, afters):
            changed[transform] += int(before != after)
            wrong[transform] += int(after != views["fabric_class"].iloc[0])
    return [{"feature_set": feature_set, "transform": t, "n": len(ok[t]), "changed": changed[t],
             "change_rate": changed[t] / len(ok[t]) if ok[t] else 0.0, "wrong_after": wrong[t],
             "not_usable": len(images) - len(ok[t])} for t in transforms]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", default=PAIRS, help="comma-separated image ids, or 'all'")
    parser.add_argument("--out", default="results/bench/invariance")
    parser.add_argument("--features-only", action="store_true", help="reuse the run's fits; recompute the feature rows")
    parser.add_argument("--scores-only", action="store_true",
                        help="reuse the run's feature tables as they are (after a change to the classifier only)")
    parser.add_argument("--overlay", help="config overlay for the transformed photos' run (as the main run's)")
    parser.add_argument("--transforms", default=",".join(PHOTO_TRANSFORMS),
                        help=f"comma-separated, of {', '.join(TRANSFORMS)} (refit: the photo as it is)")
    parser.add_argument("--prefer", nargs="+", default=[], choices=PREFER_CHOICES,
                        help="also score the record with each of these classify.choice.prefer values")
    args = parser.parse_args()
    transforms = args.transforms.split(",")
    if unknown := sorted(set(transforms) - set(TRANSFORMS)):
        parser.error(f"unknown transformation(s) {', '.join(unknown)}; choose from {', '.join(TRANSFORMS)}")
    settings = classify_config()
    out = (ROOT / args.out).resolve()
    sheet = pd.read_csv(write_sheet(args.images.split(","), out / "originals.tsv"), sep="\t", dtype=str, keep_default_na=False)
    transformed_sheet(sheet, out, transforms).to_csv(out / "samples.tsv", sep="\t", index=False)
    run = out / "run"
    reuse = ["--rerun-triggers", "mtime", "--forcerun", "features"] if args.features_only else []
    overlay = ["--configfile", "config/config.yaml", args.overlay] if args.overlay else []
    seconds = 0.0 if args.scores_only else snakemake([*overlay, "--config", f"samples={out / 'samples.tsv'}", f"results={run}", "--quiet", *reuse, "all", "--",
                         *(str(run / "features" / s / "table.parquet") for s in ("fitted", "photo"))])
    originals, tiles = run_tables(ROOT / "results")
    transformed, transformed_tiles = run_tables(run)
    images = list(sheet["image_id"])
    rows = [row for f in SETS for row in changed_predictions(f, originals, transformed, images, settings, tiles,
                                                               transformed_tiles, transforms)]
    for prefer in args.prefer:
        preferring = {**settings, "feature_set": "auto", "choice": {**settings["choice"], "prefer": prefer}}
        rows += [{**row, "feature_set": f"record auto, prefer {prefer}"}
                 for row in changed_predictions("record", originals, transformed, images, preferring, tiles, transformed_tiles,
                                                   transforms)]
    table = pd.DataFrame(rows)
    how_run = ("earlier (its feature tables reused as they are, `--scores-only`" if args.scores_only
               else f"in {seconds / 60:.1f} min (2 cores{', fits reused' if args.features_only else ''}")
    lines = ["# Invariance of predictions to the photo's rotation, zoom and colour (refitted)", "",
             f"{len(images)} images x {len(transforms)} transformations ({', '.join(transforms)}), prepared, fitted and described by the "
             f"workflow {how_run}{f', overlay `{args.overlay}`' if args.overlay else ''}). "
             f"Classifier: QDA, subspace `{settings['subspace']}`, shrinkage `{settings['reg']}`; `record` is "
             f"`{settings['feature_set']}` on fitted maps with the photo beside them ({record_how(settings)}); "
             "`record_vote` is every set voting. Changed: the model trained on every other original image "
             "predicts another class for the transformed photo than for the original. rotate30 keeps the valid centre, "
             "which the prepare stage resizes, so it also magnifies by 1.41; refit is the photo as it is, refitted.", "",
             "| feature set | transform | changed | rate | wrong after |", "|---|---|---|---|---|"]
    lines += [f"| {r.feature_set} | {r.transform} | {r.changed}/{r.n} | {100 * r.change_rate:.1f}% | {r.wrong_after} |"
              for r in table.itertuples()]
    publish(out, "invariance_fitted", table, "\n".join(lines) + "\n", float_format="%.4f")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
