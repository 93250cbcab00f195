"""The ``classify`` rule: LOOCV reports, the all-labelled model, query predictions and each image's record.

Only rows with status ``ok`` are scored, trained on or predicted; every other
image still gets a record (:data:`RECORDS_FILE`) that gives its status and reason,
which the ``physics`` rule turns into its physics JSON (:mod:`clothscope.physics.job`).

Posteriors in each image's record:

* labelled images scored by LOOCV: their leave-one-out posteriors (the model
  never saw the image), ``posterior_source: loocv``;
* queries (empty ``fabric_class``), and labelled images of a class too small
  for LOOCV: the all-labelled model's posteriors, ``posterior_source: model``.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pandas as pd

from clothscope import __version__
from clothscope.classify.feature_sets import (
    classifier_candidates,
    discordant,
    headline_set,
    inverse_rendering_gain,
    joined_table,
    joined_tiles,
    mcnemar_p,
)
from clothscope.classify.loocv import Choice, LoocvResult, candidates_model, loocv
from clothscope.classify.model import VotingModel, predict, save_model, save_untrained
from clothscope.classify.outputs import (
    ACCURACY_FILE,
    CONFUSION_CSV_FILE,
    CONFUSION_FILE,
    IMAGES_FILE,
    PER_CLASS_FILE,
    PREDICTIONS_FILE,
    RECORDS_FILE,
    SUMMARY_FILE,
)
from clothscope.classify.reports import write_reports
from clothscope.classify.rows import POSTERIOR_PREFIX, split_labelled
from clothscope.core.atomic import write_json, write_text
from clothscope.features.plots import plot_placeholder
from clothscope.features.sources import STATUS_OK
from clothscope.features.table import read_table


def _posteriors(row: pd.Series) -> dict[str, float]:
    values = {c[len(POSTERIOR_PREFIX):]: float(row[c]) for c in row.index if c.startswith(POSTERIOR_PREFIX)}
    total = sum(values.values())
    return {c: v / total for c, v in values.items()} if total > 0 else values


def _provenance(table: pd.DataFrame) -> dict[str, Any]:
    return {
        "normal_sources": sorted(set(table["normal_source"])),
        "config_hashes": sorted(set(table["config_hash"])),
        "mitsuba_variants": sorted(set(table["mitsuba_variant"])),
    }


def versus_photo_line(comparison_csv: str | os.PathLike[str] | None, source: str) -> str:
    """The feature-set report's one line on what the fit bought over the photo alone (for this source)."""
    if source == "photo":
        return "This classifier reads the photo alone (no inverse rendering)."
    if not comparison_csv:
        return "Inverse rendering against the photo alone: not measured (results/reports/feature_sets.md not built)."
    return inverse_rendering_gain(pd.read_csv(comparison_csv), headline_set(source))


def photo_only_loocv(photo_table: pd.DataFrame, photo_tiles: pd.DataFrame | None, feature_set: str, reg: float | str,
                     subspace: str, **options: Any) -> LoocvResult:
    """LOOCV of the classifier ``feature_set`` on the photo's feature table alone: what the workflow scores with
    ``features.normal_source: photo``, which runs no fit (``options``: :func:`clothscope.classify.loocv.loocv`'s
    ``choice``, ``test_tiles``, ``vote`` and ``prune``)."""
    photo = {"photo": photo_table}
    joined = joined_table(photo)
    tiles = joined_tiles(photo, None if photo_tiles is None else {"photo": photo_tiles})
    return loocv(joined[joined["status"] == STATUS_OK], [], reg, select_from=classifier_candidates(feature_set, "photo", joined.columns),
                 subspace=subspace, tiles=tiles, **options)


def without_fit_line(right_with: pd.Series, right_without: pd.Series) -> str:
    """One line: the classifier against itself on the photo alone (:func:`photo_only_loocv`), on the images both scored
    (each Series: :meth:`~clothscope.classify.loocv.LoocvResult.right_by_image`)."""
    right_with, right_without = right_with.align(right_without, join="inner")
    only_with, only_without = discordant(right_with, right_without)
    return (f"Without the fit (the same classifier on the photo alone, as `features.normal_source: photo` runs it): "
            f"{int(right_without.sum())}/{len(right_with)} against {int(right_with.sum())}/{len(right_with)} with it; "
            f"image by image, only with the fit right on {only_with} and only without it on {only_without} "
            f"(exact McNemar p = {mcnemar_p(only_with, only_without):.2g}).")


def write_summary(reports_dir: str | os.PathLike[str], title: str, feature_set: str, accuracy_line: str, versus: str) -> None:
    """``summary.md``: the classifier's accuracy and ``versus``, what the fit bought over the photo alone."""
    write_text(Path(reports_dir) / SUMMARY_FILE, f"# {title}\n\nFeature set: `{feature_set}`. {accuracy_line}\n\n{versus}\n")


def model_line(model: VotingModel, voting: bool) -> str:
    """The summary's sentence on the model for new photos: the set it uses, or the sets it averages."""
    names = ", ".join(f"`{name}`" for name in model.members)
    return (f"The model for new photos averages the posteriors of {len(model.members)} QDAs: {names}." if voting
            else f"The model for new photos uses {names}.")


def classify_job(table_path: str | os.PathLike[str], physics_path: str | os.PathLike[str], source: str, reg: float | str,
                 reports_dir: str | os.PathLike[str], model_dir: str | os.PathLike[str],
                 log: Any = None, *, feature_set: str,
                 comparison_csv: str | os.PathLike[str] | None = None,
                 photo_table_path: str | os.PathLike[str] | None = None, subspace: str,
                 settings: dict[str, Any] | None = None,
                 tile_paths: dict[str, str | os.PathLike[str]] | None = None,
                 choice: Choice | None = None, test_tiles: bool = False, prune: float = 0.0) -> dict[str, Any]:
    """Run the classifier stage for one normal source.

    Parameters
    ----------
    table_path
        The feature table (Parquet).
    physics_path
        ``config/physics.yaml``, recorded in the model for ``clothscope predict``.
    source
        ``truth`` or ``fitted`` (for titles and records).
    reg
        QDA shrinkage, ``"auto"`` or a number in [0, 1].
    reports_dir
        Receives ``accuracy.json``, ``confusion.{csv,png}``, ``per_class.csv``,
        ``predictions.csv``, ``images.tsv`` (every image's status and prediction) and
        :data:`RECORDS_FILE` (each image's record for the ``physics`` rule).
    model_dir
        Receives the all-labelled model as data (:func:`clothscope.classify.model.save_model`).
    feature_set
        Columns the classifier reads (:func:`clothscope.classify.feature_sets.classifier_candidates`);
        ``auto`` chooses among them inside each LOOCV fold, and for the model on all labelled images;
        ``vote`` averages the posteriors of a QDA on each of them not pruned at ``prune``, in each fold and in the
        model.
    comparison_csv
        ``feature_sets.csv``, for the line on what the fit bought over the photo alone (``summary.md``).
    photo_table_path
        The ``photo`` feature table, joined to ``table_path`` by image id (the photo's feature sets need it).
    subspace
        Feature space of the QDA (:func:`clothscope.classify.qda.make_qda`).
    settings
        The ``prepare``, ``fit``, ``features`` and ``variant`` config the table's images were
        processed with; recorded in the model so that ``clothscope predict`` processes a photo alike.
    tile_paths
        Each source's tile table (``features/<source>/tiles/table.parquet``): extra training rows
        (:func:`clothscope.classify.feature_sets.joined_tiles`); without them, whole images only.
    choice
        How ``auto`` picks its set (:class:`clothscope.classify.loocv.Choice`; None: the best inner accuracy).
    test_tiles
        Score each image by the mean posterior of its whole row and its tiles (``classify.test_tiles: mean``),
        in LOOCV and as a query; recorded in the model, so ``clothscope predict`` scores a photo alike.
    prune
        With ``vote``: the sign test level at which the sets the best one beats plainly are left out
        (``classify.prune``; 0: every set votes).
    """
    tables = {source: read_table(table_path)}
    if photo_table_path and source != "photo":
        tables["photo"] = read_table(photo_table_path)
    table = joined_table(tables)
    tile_tables = {s: read_table(path) for s, path in (tile_paths or {}).items()}
    tiles = joined_tiles(tables, tile_tables)
    candidates = classifier_candidates(feature_set, source, table.columns)
    ok = table[table["status"] == STATUS_OK]
    labelled, queries = split_labelled(ok)
    provenance = _provenance(table)
    problems = []
    voting = feature_set == "vote"
    try:
        result = loocv(ok, [], reg, select_from=candidates, subspace=subspace, tiles=tiles, choice=choice,
                       test_tiles=test_tiles, vote=voting, prune=prune)
    except ValueError as err:  # too few labelled classes or images: no scores, the run goes on
        result, problems = None, [f"LOOCV not run: {str(err).splitlines()[0]}"]
    try:
        model = candidates_model(ok, candidates, reg, subspace, tiles, choice=choice, vote=voting, prune=prune)
    except ValueError as err:
        model = None
        problems.append(f"no model trained: {str(err).splitlines()[0]}")
    scored_tiles = tiles if test_tiles else None
    query_predictions = predict(model, queries, scored_tiles) if model is not None else pd.DataFrame(columns=["image_id", "predicted_class"])
    if result is not None:
        title = f"QDA, leave-one-out, {source} maps, {feature_set} feature set ({result.correct}/{result.n} correct)"
        write_reports(result, query_predictions, reports_dir, title)
        accuracy_line = (f"LOOCV accuracy {100 * result.accuracy:.1f}% ({result.correct}/{result.n}; 95% Wilson interval "
                         f"{100 * result.wilson_low:.1f}-{100 * result.wilson_high:.1f}%; chance {100 * result.chance_uniform:.1f}%).")
    else:
        title = f"QDA, {source} maps, {feature_set} feature set"
        _write_unscored(reports_dir, source, problems, query_predictions)
        accuracy_line = "; ".join(problems) + "."
    if result is not None and result.selected:
        accuracy_line += f" {'Sets that voted, folds' if voting else 'Sets the folds chose'}: {result.selected_counts()}."
        if choice is not None and choice.prefer and not voting:
            accuracy_line += f" Preferred set `{choice.prefer}`, left only where a sign test at alpha {choice.alpha:g} said so."
    if model is not None:
        accuracy_line += f" {model_line(model, voting)}"
    versus = versus_photo_line(comparison_csv, source)
    if result is not None and source == "fitted" and "photo" in tables:
        try:
            without = photo_only_loocv(tables["photo"], tile_tables.get("photo"), feature_set, reg, subspace, choice=choice,
                                       test_tiles=test_tiles, vote=voting, prune=prune)
            versus += "\n\n" + without_fit_line(result.right_by_image(), without.right_by_image())
        except ValueError as err:  # the photo's rows alone too few to score: say so, the run goes on
            versus += f"\n\nWithout the fit: not scored ({str(err).splitlines()[0]})."
    write_summary(reports_dir, title, feature_set, accuracy_line, versus)
    if model is not None:
        save_model(model, model_dir, metadata={"normal_source": source, "feature_set": feature_set,
                                                "chosen_set": "+".join(model.members),
                                                "choice": {"prefer": choice.prefer, "alpha": choice.alpha}
                                                if choice and not voting else None,
                                                "prune": prune if voting else None,
                                                "test_tiles": "mean" if test_tiles else "none",
                                                "feature_table": str(table_path), **provenance,
                                                "n_labelled": int(len(labelled)), "settings": dict(settings or {}),
                                                "physics_table": str(physics_path),
                                                "loocv_accuracy": float(result.accuracy) if result is not None else None})
    else:
        save_untrained(model_dir, "; ".join(problems), {"normal_source": source, **provenance})

    loo = result.predictions.set_index("image_id") if result is not None else pd.DataFrame(columns=["predicted_class"])
    query_ids = set(query_predictions["image_id"].astype(str))
    # labelled images a too-small class kept out of LOOCV: posteriors from the all-labelled model
    rest = labelled[~labelled["image_id"].astype(str).isin(loo.index)]
    rest_predictions = predict(model, rest, scored_tiles) if model is not None else pd.DataFrame(columns=["image_id", "predicted_class"])
    model_rows = pd.concat([query_predictions, rest_predictions], ignore_index=True).set_index("image_id")

    summary, records = [], []
    for _, row in table.iterrows():
        image_id = str(row["image_id"])
        label = str(row["fabric_class"] or "").strip()
        record: dict[str, Any] = {
            "image_id": image_id, "fabric_class": label, "normal_source": source, "status": row["status"],
            "reason": row["reason"], "config_hash": row["config_hash"], "mitsuba_variant": row["mitsuba_variant"],
            "clothscope_version": __version__, "posterior_source": None, "predicted_class": None, "posteriors": None,
        }
        if row["status"] == STATUS_OK and image_id not in loo.index and image_id not in model_rows.index:
            record["reason"] = "; ".join(problems) or "not classified"
        elif row["status"] == STATUS_OK:
            if image_id in loo.index:
                prediction, record["posterior_source"] = loo.loc[image_id], "loocv"
            else:
                prediction, record["posterior_source"] = model_rows.loc[image_id], "model"
            posteriors = _posteriors(prediction)
            record["predicted_class"] = str(prediction["predicted_class"])
            record["posteriors"] = posteriors
        records.append(record)
        split = "excluded" if row["status"] != STATUS_OK else ("query" if image_id in query_ids else record["posterior_source"] or "unclassified")
        summary.append({"image_id": image_id, "fabric_class": label, "status": row["status"], "split": split,
                        "predicted_class": record["predicted_class"] or "",
                        "posterior": f"{max(record['posteriors'].values()):.6f}" if record["posteriors"] else "",
                        "reason": record["reason"]})
    write_json(Path(reports_dir) / RECORDS_FILE, records)
    write_text(Path(reports_dir) / IMAGES_FILE, pd.DataFrame(summary).to_csv(sep="\t", index=False, lineterminator="\n"))
    if log is not None:
        for problem in problems:
            log.warning("%s", problem)
    if result is None:
        return {"correct": 0, "n": 0, "accuracy": None, "queries": len(queries), "problems": problems}
    if log is not None:
        log.info("%s: LOOCV %d/%d, %d queries, %d images excluded", source, result.correct, result.n, len(queries),
                 int((table["status"] != STATUS_OK).sum()))
    return {"correct": result.correct, "n": result.n, "accuracy": result.accuracy, "queries": len(queries)}


def _write_unscored(reports_dir: str | os.PathLike[str], source: str, problems: list[str], queries: pd.DataFrame) -> None:
    """The report files of :func:`clothscope.classify.reports.write_reports` when LOOCV could not run, saying why."""
    out = Path(reports_dir)
    reason = "; ".join(problems)
    write_json(out / ACCURACY_FILE, {"title": f"QDA, {source} normal maps", "status": "not run", "reason": reason,
                                     "n": 0, "correct": 0, "n_queries": int(len(queries))})
    write_text(out / CONFUSION_CSV_FILE, "true_class\n")
    write_text(out / PER_CLASS_FILE, "class,support,predicted,correct,precision,recall\n")
    frame = queries.copy()
    frame["true_class"], frame["split"] = "", "query"
    write_text(out / PREDICTIONS_FILE, frame.to_csv(index=False, lineterminator="\n"))
    plot_placeholder(out / CONFUSION_FILE, f"QDA, {source} normal maps", reason)
