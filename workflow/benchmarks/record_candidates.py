"""Benchmark: the classifier of record with and without the photo's own column sets among its candidates.

    .venv/bin/python workflow/benchmarks/record_candidates.py RUN [RUN ...] [--name record_candidates]
        [--ensemble K ... | --criterion NAME ... | --prefer SET ... | --vote | --prune A ... [--fitted-of-others SEED]
         | --add-photo GROUP ...]

For each run folder, the fitted and photo feature tables are joined as the ``classify`` rule joins
them, and the ``auto`` classifier of record is scored by the same LOOCV (a column set chosen inside
each fold by the fold's training images only) with two candidate lists: the fitted maps' sets with
``photo_structure`` and ``plus_photo`` (before 2026-11-25), and the same with the photo's radial
profile, paper features, LBP and structure + LBP added
(:data:`clothscope.classify.feature_sets.PHOTO_GROUPS`, the default since; structure + spectrum rings joined them on
2026-12-07). Writes
``results/bench/<name>.{csv,md}``: per run and list, images right, and the sets the folds chose.
Nothing is chosen here.

``--ensemble K ...`` scores an alternative to choosing one set per fold: each fold
averages the QDA posteriors of the K default candidates with the best inner cross-validation
accuracy on its training images (K = 1 is the classifier of record). It was measured against
a rule written before scoring and rejected (``docs/design.md``); the option keeps the figures
reproducible.

``--criterion NAME ...`` scores other inner criteria for the choice of one set per fold
(:data:`CRITERIA`): ``accuracy`` (the classifier of record: one stratified 5-fold split),
``logloss`` (the mean log posterior of the true class, floored at 1e-6, on the same split),
``tiebreak`` (accuracy, ties broken by ``logloss``) and ``repeated`` (accuracy over three
repeats of the split). Measured against a rule written before scoring and rejected
(``docs/design.md``).

``--vote`` scores the record's ``auto`` choice against ``classify.feature_set: vote`` (the mean posterior
of a QDA on every candidate set, nothing chosen; ``docs/design.md``, "The classifier of record, voting").

``--prune A ...`` scores the record's vote with every set voting against the vote pruned at each sign test
level A (``classify.prune``: each fold leaves out the sets the best one beats plainly in an inner cross-validation
of its training images; ``docs/design.md``, "Pruning the vote"). ``--fitted-of-others SEED`` first gives each image
the fitted features and tiles of another image (a permutation drawn with SEED, :func:`fitted_of_others`): fitted
maps that carry no class, the failure pruning is meant to absorb.

``--add-photo GROUP ...`` scores the record as configured (its vote, pruned at ``classify.prune``) without and with the
photo's columns of each ``GROUP`` (a :func:`clothscope.classify.feature_sets.group_columns` group, such as ``spectrum``)
among its candidates as ``photo_<GROUP>``: two lists per group, so the comparison holds whether or not the default list
has that set (``photo_spectrum`` joined it on 2026-12-07; ``docs/design.md``, "The photo's spectrum rings in the vote").
The reports of 2026-12-07 hold the "with" row only, made before the member was a default; their "without" figure is
each run's own record.

``--prefer SET ...`` scores the record with each ``classify.choice.prefer`` (``none``: the best inner
accuracy; a candidate's name: that set unless the best beats it by the sign test of
:class:`clothscope.classify.loocv.Choice`, at the config's ``classify.choice.alpha``, or at each level
of ``--alpha A ...``).
"""
from __future__ import annotations

import argparse
from functools import partial
from pathlib import Path

import numpy as np
import pandas as pd
from class_subsets import classify_config
from harness import ROOT, publish, record_inputs, record_loocv, run_tables, shown

from clothscope.classify.feature_sets import JOINED_PROVENANCE, PHOTO_GROUPS, source_columns
from clothscope.classify.loocv import Choice, LoocvResult, choose_columns, inner_folds
from clothscope.classify.model import predict, train_model
from clothscope.classify.rows import posterior_column, split_labelled
from clothscope.core.config import config_schema
from clothscope.features.sources import STATUS_OK

LISTS = ("without the photo's own sets", "with them (default)")
#: the values of ``classify.choice.prefer`` (the config schema's enum)
PREFER_CHOICES = tuple(config_schema()["properties"]["classify"]["properties"]["choice"]["properties"]["prefer"]["enum"])


def result_row(run: str, candidates: str, result: LoocvResult) -> dict:
    """One report row: the run, how the record combined its candidates, and what its LOOCV got right."""
    return {"run": run, "candidates": candidates, "correct": result.correct, "images": result.n,
            "accuracy": result.accuracy, "folds_chose": result.selected_counts()}


def run_rows(run: Path) -> list[dict]:
    """The classifier of record's LOOCV on one run, under each candidate list."""
    ok, tiles, everything = record_inputs(*run_tables(run), "auto")
    without = {name: columns for name, columns in everything.items() if name not in PHOTO_GROUPS}
    settings = classify_config()
    rows = []
    for label, candidates in zip(LISTS, (without, everything)):
        result = record_loocv(ok, candidates, tiles, settings, vote=False)
        rows.append(result_row(shown(run), label, result))
    return rows


def held_out_posterior(training: pd.DataFrame, columns: list[str], held_out: pd.DataFrame, classes: list[str],
                       settings: dict, tiles: pd.DataFrame | None) -> np.ndarray:
    """The posterior over ``classes`` of the one ``held_out`` row, by the record's model trained on ``training``."""
    model = train_model(training, columns, settings["reg"], settings["subspace"], tiles)
    return predict(model, held_out)[[posterior_column(c) for c in classes]].to_numpy(float)[0]


def ensemble_rows(run: Path, sizes: list[int]) -> list[dict]:
    """LOOCV of the posterior average of the best ``k`` default candidates (by each fold's inner CV), per ``k``."""
    ok, tiles, candidates = record_inputs(*run_tables(run), "auto")
    settings = classify_config()
    labelled = split_labelled(ok)[0].reset_index(drop=True)
    truth = labelled["fabric_class"].astype(str).to_numpy()
    classes = sorted(set(truth))
    correct = dict.fromkeys(sizes, 0)
    for i in range(len(labelled)):
        rows = labelled.drop(index=i)
        scores = choose_columns(rows, candidates, settings["reg"], settings["subspace"], tiles)[1]
        ranked = sorted(scores, key=lambda name: (-scores[name], list(candidates).index(name)))[:max(sizes)]
        members = [held_out_posterior(rows, candidates[name], labelled.iloc[[i]], classes, settings, tiles)
                   for name in ranked]
        for k in sizes:
            correct[k] += int(classes[int(np.mean(members[:k], axis=0).argmax())] == truth[i])
    label = {k: f"posteriors of the best {k} averaged" + (" (the classifier of record)" if k == 1 else "") for k in sizes}
    return [{"run": shown(run), "candidates": label[k], "correct": correct[k], "images": len(labelled),
             "accuracy": correct[k] / len(labelled), "folds_chose": ""} for k in sizes]


CRITERIA = ("accuracy", "logloss", "tiebreak", "repeated")


def inner_score(rows: pd.DataFrame, columns: list[str], reg: float | str, subspace: str, tiles: pd.DataFrame | None,
                criterion: str) -> float | tuple[float, float]:
    """The inner cross-validation score of one column set on a fold's training ``rows`` by ``criterion`` (higher is
    better), over the folds of :func:`clothscope.classify.loocv.inner_folds`."""
    correct, log_posterior, scored = 0, 0.0, 0
    for model, X, y in inner_folds(rows, columns, reg, subspace, tiles, repeats=3 if criterion == "repeated" else 1):
        correct += int((model.predict(X) == y).sum())
        if criterion in ("logloss", "tiebreak"):
            truth_column = [list(model.classes_).index(c) for c in y]
            posterior = model.predict_proba(X)[np.arange(len(y)), truth_column]
            log_posterior += float(np.log(np.maximum(posterior, 1e-6)).sum())
        scored += len(y)
    accuracy, logloss = correct / scored, log_posterior / scored
    return {"accuracy": accuracy, "repeated": accuracy, "logloss": logloss, "tiebreak": (accuracy, logloss)}[criterion]


def criterion_rows(run: Path, criteria: list[str]) -> list[dict]:
    """LOOCV of the classifier of record with each inner ``criterion`` choosing the fold's column set."""
    ok, tiles, candidates = record_inputs(*run_tables(run), "auto")
    settings = classify_config()
    rows = []
    for criterion in criteria:
        result = record_loocv(ok, candidates, tiles, settings, score=partial(inner_score, criterion=criterion),
                              choice=None, vote=False)
        rows.append(result_row(shown(run), f"inner criterion: {criterion}"
                               + (" (the classifier of record)" if criterion == "accuracy" else ""), result))
    return rows


def prefer_rows(run: Path, preferred: list[str], alphas: list[float] | None = None) -> list[dict]:
    """LOOCV of the classifier of record with each preferred set (``none``: the best inner accuracy, scored once,
    since it runs no sign test), at each sign test level of ``alphas`` (None: the config's ``classify.choice.alpha``)."""
    ok, tiles, candidates = record_inputs(*run_tables(run), "auto")
    settings = classify_config()
    levels = alphas or [settings["choice"]["alpha"]]
    rows = []
    for prefer, alpha in ((p, a) for p in preferred for a in (levels[:1] if p == "none" else levels)):
        choice = Choice.from_config({**settings["choice"], "prefer": prefer, "alpha": alpha})
        result = record_loocv(ok, candidates, tiles, settings, choice=choice, vote=False)
        rows.append(result_row(shown(run), f"prefer {prefer}" + ("" if choice.prefer is None
                                                                 else f" (alpha {choice.alpha:g})"), result))
    return rows


def vote_rows(run: Path) -> list[dict]:
    """LOOCV of the classifier of record choosing one set per fold (``auto``) and averaging them all (``vote``)."""
    ok, tiles, candidates = record_inputs(*run_tables(run), "auto")
    settings = classify_config()
    rows = []
    for feature_set in ("auto", "vote"):
        result = record_loocv(ok, candidates, tiles, settings, vote=feature_set == "vote")
        rows.append(result_row(shown(run), f"feature_set: {feature_set}", result))
    return rows


def fitted_of_others(tables: dict[str, pd.DataFrame], tiles: dict[str, pd.DataFrame],
                     seed: int) -> tuple[dict[str, pd.DataFrame], dict[str, pd.DataFrame]]:
    """The run's tables with each usable image's fitted features (and fitted tiles) replaced by those of another
    usable image, drawn by a random permutation with ``seed``: fitted maps that carry no class, beside the true photo."""
    fitted = tables["fitted"].reset_index(drop=True)
    ok = np.flatnonzero(fitted["status"].to_numpy() == STATUS_OK)
    donors = ok[np.random.default_rng(seed).permutation(len(ok))]
    features = [c for c in fitted.columns if c not in JOINED_PROVENANCE]
    spoiled = fitted.copy()
    spoiled.loc[ok, features] = fitted.loc[donors, features].to_numpy()
    out_tiles = dict(tiles)
    if "fitted" in tiles:
        ids = fitted["image_id"].astype(str).to_numpy()
        by_image = {image: part for image, part in tiles["fitted"].assign(
            image_id=lambda t: t["image_id"].astype(str)).groupby("image_id")}
        out_tiles["fitted"] = pd.concat([by_image[ids[d]].assign(image_id=ids[i]) for i, d in zip(ok, donors)
                                         if ids[d] in by_image], ignore_index=True)
    return {**tables, "fitted": spoiled}, out_tiles


def prune_rows(run: Path, levels: list[float], spoil_seed: int | None = None) -> list[dict]:
    """LOOCV of the classifier of record's vote with every candidate and with those the best beats plainly in each
    fold's inner cross-validation left out, at each sign test level of ``levels``; with ``spoil_seed``, on
    :func:`fitted_of_others` of the run's tables."""
    tables, tile_tables = run_tables(run)
    if spoil_seed is not None:
        tables, tile_tables = fitted_of_others(tables, tile_tables, spoil_seed)
    ok, tiles, candidates = record_inputs(tables, tile_tables, "auto")
    settings = classify_config()
    label = shown(run) + ("" if spoil_seed is None else f" (fitted features of other images, seed {spoil_seed})")
    rows = []
    for level in [0.0, *levels]:
        result = record_loocv(ok, candidates, tiles, settings, vote=True, prune=level)
        rows.append(result_row(label, f"vote, pruned at {level:g}" if level else "vote, every set", result))
    return rows


def added_photo_rows(run: Path, groups: list[str]) -> list[dict]:
    """LOOCV of the classifier of record as configured, without and with the photo's columns of each group among its
    candidates (as ``photo_<group>``, last; a candidate of that name already in the list is the one left out)."""
    ok, tiles, candidates = record_inputs(*run_tables(run), "auto")
    settings = classify_config()
    rows = []
    for group in groups:
        name, added = f"photo_{group}", source_columns(ok.columns, "photo", group)
        if not added:
            raise ValueError(f"{shown(run)}: the photo's table has no columns of group {group!r}")
        without = {key: columns for key, columns in candidates.items() if key != name}
        for label, listed in ((f"the record without {name}", without), (f"the record with {name}", {**without, name: added})):
            rows.append(result_row(shown(run), label, record_loocv(ok, listed, tiles, settings)))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="run folders (each with features/fitted and features/photo)")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--name", default="record_candidates")
    parser.add_argument("--ensemble", type=int, nargs="+", metavar="K",
                        help="score the posterior average of the K best candidates instead (K >= 1)")
    parser.add_argument("--criterion", nargs="+", choices=CRITERIA,
                        help="score these inner criteria for choosing each fold's set instead")
    parser.add_argument("--prefer", nargs="+", choices=PREFER_CHOICES,
                        help="score the record with each of these classify.choice.prefer values (none or a set's name)")
    parser.add_argument("--alpha", type=float, nargs="+", metavar="A",
                        help="with --prefer: at each of these classify.choice.alpha levels (default: the config's)")
    parser.add_argument("--vote", action="store_true",
                        help="score the record's auto choice against its vote over every candidate (feature_set: vote)")
    parser.add_argument("--prune", type=float, nargs="+", metavar="A",
                        help="score the record's vote with every set and pruned at each of these sign test levels")
    parser.add_argument("--add-photo", nargs="+", metavar="GROUP",
                        help="score the record without and with the photo's columns of each GROUP (such as spectrum) "
                             "among its candidates")
    parser.add_argument("--fitted-of-others", type=int, metavar="SEED",
                        help="with --prune: give each image the fitted features of another (a permutation drawn with SEED)")
    args = parser.parse_args()
    if args.alpha and (not args.prefer or not all(0.0 < a < 1.0 for a in args.alpha)):
        parser.error("--alpha needs --prefer and levels between 0 and 1")
    if args.ensemble and min(args.ensemble) < 1:
        parser.error("--ensemble sizes must be >= 1")
    if sum(bool(option) for option in (args.ensemble, args.criterion, args.prefer, args.vote, args.prune,
                                         args.add_photo)) > 1:
        parser.error("give one of --ensemble, --criterion, --prefer, --vote, --prune and --add-photo")
    if args.prune and not all(0.0 < a < 1.0 for a in args.prune):
        parser.error("--prune levels must be between 0 and 1")
    if args.fitted_of_others is not None and not args.prune:
        parser.error("--fitted-of-others needs --prune")
    rows_of = vote_rows if args.vote else run_rows
    if args.ensemble:
        rows_of = lambda run: ensemble_rows(run, sorted(set(args.ensemble)))  # noqa: E731
    elif args.criterion:
        rows_of = lambda run: criterion_rows(run, list(dict.fromkeys(args.criterion)))  # noqa: E731
    elif args.prune:
        rows_of = lambda run: prune_rows(run, sorted(set(args.prune)), args.fitted_of_others)  # noqa: E731
    elif args.add_photo:
        rows_of = lambda run: added_photo_rows(run, list(dict.fromkeys(args.add_photo)))  # noqa: E731
    elif args.prefer:
        rows_of = lambda run: prefer_rows(run, list(dict.fromkeys(args.prefer)), args.alpha)  # noqa: E731
    table = pd.DataFrame([row for run in args.runs for row in rows_of(ROOT / run)])
    how = ("posteriors of the best K candidates averaged in each fold" if args.ensemble
           else "one set chosen inside each fold, or every candidate's posterior averaged" if args.vote
           else "candidates' posteriors averaged, less those plainly beaten in each fold" if args.prune
           else "as configured, without and with the photo's columns of each group among its candidates" if args.add_photo
           else "column set chosen inside each fold" + (", by each inner criterion" if args.criterion else "")
           + (", by each preferred set" if args.prefer else ""))
    lines = [f"Classifier of record (LOOCV, {how}), by its candidate list:", "",
             "| run | candidates | correct | accuracy | the folds chose |", "|---|---|---|---|---|"]
    lines += [f"| `{r.run}` | {r.candidates} | {r.correct}/{r.images} | {r.accuracy:.1%} | {r.folds_chose} |"
              for r in table.itertuples()]
    publish(args.out, args.name, table, "\n".join(lines) + "\n", float_format="%.4g")


if __name__ == "__main__":
    main()
