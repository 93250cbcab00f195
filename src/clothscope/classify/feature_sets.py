"""Feature sets side by side: what the fitted maps buy over the photo alone, on the same images.

A *feature set* is a list of (source, column group) parts: the paper's
features, this project's structure descriptor, the BSDF, or the plain LBP
baseline, taken from the ``fitted``, ``photo`` or ``truth`` feature table.
:func:`compare_feature_sets` scores every set whose sources are present by
the same LOOCV QDA (:func:`clothscope.classify.loocv.loocv`) on the same images:
those usable in every compared source. Nothing here is tuned on the scores.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
from scipy.stats import binomtest

from clothscope.classify.loocv import loocv
from clothscope.core.atomic import write_text
from clothscope.features.sources import STATUS_OK
from clothscope.features.structure import (
    LBP_COLUMNS,
    SHADE_COLUMNS,
    SPECTRUM_COLUMNS,
    STRUCTURE_COLUMNS,
    TILE_FEATURES,
    WEAVE_COLUMNS,
)
from clothscope.features.table import FIT_COLUMNS
from clothscope.prepare.rejections import thread_scale_line

#: Column groups of a feature table. The fitted BRDF's columns hold what the fit left unexplained beside
#: roughness and specular (docs/design.md, "What the fit cannot explain").
BRDF_COLUMNS = ("roughness", "specular_norm", *FIT_COLUMNS)
#: Column groups the ``auto`` feature set chooses from, inside each LOOCV fold (ties go to the first), and whose
#: QDAs the ``vote`` feature set averages.
AUTO_GROUPS = ("structure_brdf", "profile_brdf", "paper", "lbp", "texture_brdf", "texture_shade_brdf")
#: Column groups a joined table (:func:`joined_table`) keeps of each source: the ``auto`` groups and the spectrum rings.
JOINED_GROUPS = (*AUTO_GROUPS, "spectrum")
#: Group names that stand for all of :data:`AUTO_GROUPS`: ``auto`` chooses one inside each fold, ``vote`` averages them.
CANDIDATE_GROUPS = ("auto", "vote")
#: The photo's own column sets beside a fitted or true classifier (``photo_structure`` is named above them):
#: its radial profile, the paper's features, LBP, structure with LBP, and structure with the spectrum rings (the photo's
#: BRDF columns are zero, so dropped).
PHOTO_GROUPS = {"photo_profile": "profile", "photo_paper": "paper", "photo_lbp": "lbp", "photo_texture": "texture",
                "photo_spectrum": "spectrum"}
#: Sources whose structure descriptor takes its weave rings ``w_*`` into every set that holds it (docs/design.md,
#: "The weave rings"); the other sources' tables hold the rings too, and their sets leave them out.
RING_SOURCES = ("photo", "fitted")
#: Provenance columns a joined table keeps from its first source.
JOINED_PROVENANCE = ("image_id", "fabric_class", "status", "reason", "normal_source", "mitsuba_variant", "config_hash")


def group_columns(group: str, table_columns: list[str] | pd.Index) -> list[str]:
    """The columns of one group present in a table.

    ``paper``: roughness, specular_norm, ``r_*``, ``z_*``, ``n_peaks`` and any
    ``x_*`` extras; ``structure``: ``s_*`` and the weave rings ``w_*``; ``brdf``: roughness,
    specular_norm and the fit's log unexplained share ``unexplained``; ``structure_brdf``: both; ``profile``: the radial
    profile ``s_prof_*``; ``profile_brdf``: it and the BRDF; ``lbp``: the LBP
    baseline; ``spectrum``: structure and the spectrum rings ``p_*``; ``texture``: structure and LBP;
    ``texture_brdf``: with the BRDF; ``shade``: ``a_*``,
    the structure descriptor of a fitted shade texture;
    ``texture_shade_brdf``: ``texture_brdf`` and ``shade`` together.
    """
    names = list(table_columns)
    if group == "paper":
        return [c for c in names if c in ("roughness", "specular_norm", "n_peaks") or c.startswith(("r_", "z_", "x_"))]
    profile = tuple(c for c in STRUCTURE_COLUMNS if c.startswith("s_prof_"))
    structure = STRUCTURE_COLUMNS + WEAVE_COLUMNS
    wanted = {"structure": structure, "brdf": BRDF_COLUMNS, "lbp": LBP_COLUMNS,
              "structure_brdf": structure + BRDF_COLUMNS, "profile": profile, "profile_brdf": profile + BRDF_COLUMNS,
              "spectrum": structure + SPECTRUM_COLUMNS, "texture": structure + LBP_COLUMNS,
              "texture_brdf": structure + LBP_COLUMNS + BRDF_COLUMNS, "shade": SHADE_COLUMNS,
              "texture_shade_brdf": structure + LBP_COLUMNS + SHADE_COLUMNS + BRDF_COLUMNS}.get(group)
    if wanted is None:
        raise ValueError(f"unknown feature group {group!r}")
    return [c for c in names if c in wanted]


def source_columns(columns: list[str] | pd.Index, source: str, group: str) -> list[str]:
    """A group's columns of one source in a joined table (``<source>.<column>``); ``auto``, ``vote``: every AUTO_GROUPS column.

    The weave rings ``w_*`` are left out for a source not in :data:`RING_SOURCES`.
    """
    prefix = f"{source}."
    own = [c[len(prefix):] for c in columns if c.startswith(prefix)]
    if source not in RING_SOURCES:
        own = [c for c in own if c not in WEAVE_COLUMNS]
    groups = AUTO_GROUPS if group in CANDIDATE_GROUPS else (group,)
    return [prefix + c for c in dict.fromkeys(c for g in groups for c in group_columns(g, own))]


def auto_candidates(columns: list[str] | pd.Index, source: str) -> dict[str, list[str]]:
    """The column sets of one source that the ``auto`` feature set chooses from and ``vote`` averages (:data:`AUTO_GROUPS`)."""
    return {group: source_columns(columns, source, group) for group in AUTO_GROUPS}


@dataclass(frozen=True)
class FeatureSet:
    """A named list of (source, group) parts."""

    name: str
    description: str
    parts: tuple[tuple[str, str], ...]

    @property
    def sources(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(source for source, _ in self.parts))

    @property
    def photo_only(self) -> bool:
        return self.sources == ("photo",)

    def pooled(self) -> tuple[str, bool] | None:
        """The source whose :data:`AUTO_GROUPS` this set pools (a :data:`CANDIDATE_GROUPS` part), and whether it
        votes over them rather than choosing one; None for a set of fixed columns."""
        part = next(((source, group) for source, group in self.parts if group in CANDIDATE_GROUPS), None)
        return None if part is None else (part[0], part[1] == "vote")


FEATURE_SETS = (
    FeatureSet("paper_fitted", "the paper's features (Algorithm 2 + BRDF) on fitted normal maps", (("fitted", "paper"),)),
    FeatureSet("structure_fitted", "structure descriptor of the fitted map (features.fitted_field)", (("fitted", "structure"),)),
    FeatureSet("structure_brdf_fitted", "structure descriptor of the fitted map + fitted BRDF",
               (("fitted", "structure_brdf"),)),
    FeatureSet("texture_brdf_fitted", "structure descriptor and LBP of the fitted map + fitted BRDF",
               (("fitted", "texture_brdf"),)),
    FeatureSet("paper_photo", "Algorithm 2 on the photo's grey levels", (("photo", "paper"),)),
    FeatureSet("structure_photo", "structure descriptor of the photo's luminance", (("photo", "structure"),)),
    FeatureSet("spectrum_photo", "structure descriptor and spectrum rings of the photo's luminance", (("photo", "spectrum"),)),
    FeatureSet("lbp_photo", "uniform LBP histograms (8/1, 16/2, 24/3) of the photo's luminance", (("photo", "lbp"),)),
    FeatureSet("fitted_plus_photo", "structure + BRDF from the fit, with the photo's structure descriptor",
               (("fitted", "structure_brdf"), ("photo", "structure"))),
    FeatureSet("photo_plus_brdf", "the photo's structure descriptor with the fitted BRDF (roughness, specular, unexplained share)",
               (("photo", "structure"), ("fitted", "brdf"))),
    FeatureSet("auto_fitted", "chosen inside each fold among structure+BRDF, profile+BRDF, paper, LBP, texture+BRDF and texture+shade+BRDF on fitted maps",
               (("fitted", "auto"),)),
    FeatureSet("auto_photo", "chosen inside each fold among the same sets on the photo", (("photo", "auto"),)),
    FeatureSet("auto_truth", "chosen inside each fold among the same sets on ground-truth maps", (("truth", "auto"),)),
    FeatureSet("vote_fitted", "mean posterior of the QDAs of the same sets on fitted maps (nothing chosen)", (("fitted", "vote"),)),
    FeatureSet("vote_photo", "mean posterior of the QDAs of the same sets on the photo", (("photo", "vote"),)),
    FeatureSet("vote_truth", "mean posterior of the QDAs of the same sets on ground-truth maps", (("truth", "vote"),)),
    FeatureSet("paper_truth", "the paper's features on ground-truth normal maps", (("truth", "paper"),)),
    FeatureSet("structure_truth", "structure descriptor of the true relief alone (no BRDF)", (("truth", "structure"),)),
    FeatureSet("structure_brdf_truth", "structure descriptor of the true relief + true BRDF", (("truth", "structure_brdf"),)),
)


def headline_set(source: str) -> str:
    """The feature set of ``source`` that the report's first line and each classifier's summary set against the photo:
    the vote over its column sets (docs/design.md, "Voting over the candidate sets instead of choosing one")."""
    return f"vote_{source}"


#: Accuracy (a fraction) within which :func:`relief_line` counts a set as keeping what the true relief holds.
RELIEF_MARGIN = 0.10


def usable(table: pd.DataFrame) -> pd.DataFrame:
    """Labelled rows with status ok, indexed by image id."""
    label = table["fabric_class"].fillna("").astype(str).str.strip()
    return table[(table["status"] == STATUS_OK) & (label != "")].set_index("image_id")


def common_images(tables: dict[str, pd.DataFrame]) -> list[str]:
    """Ids of the labelled images usable in every table, in the first table's order."""
    ids: list[str] | None = None
    for table in tables.values():
        ok = [str(i) for i in usable(table).index]
        ids = ok if ids is None else [i for i in ids if i in set(ok)]
    return ids or []


def joined_features(feature_set: FeatureSet, tables: dict[str, pd.DataFrame], images: list[str]) -> tuple[pd.DataFrame, list[str]]:
    """The :func:`joined_table` rows of ``images`` and the set's columns (``<source>.<column>``)."""
    frame = joined_table({source: tables[source] for source in feature_set.sources})
    frame = frame.set_index("image_id").loc[images].reset_index()
    columns = list(dict.fromkeys(c for source, group in feature_set.parts for c in source_columns(frame.columns, source, group)))
    return frame, columns


def _unscored_row(feature_set: FeatureSet, reason: str) -> dict[str, object]:
    """A report row for a set that could not be scored, saying why."""
    return {"feature_set": feature_set.name, "description": feature_set.description,
            "sources": "+".join(feature_set.sources), "photo_only": feature_set.photo_only, "n_features": 0, "n": 0,
            "correct": 0, "accuracy": 0.0, "wilson_low": 0.0, "wilson_high": 0.0, "chance": 0.0,
            "status": "not scored", "reason": " ".join(reason.split())}


def score_feature_set(feature_set: FeatureSet, tables: dict[str, pd.DataFrame], images: list[str],
                      reg: float | str, subspace: str,
                      tile_tables: dict[str, pd.DataFrame] | None = None,
                      test_tiles: bool = False) -> tuple[dict[str, object], pd.Series | None]:
    """LOOCV of one feature set on ``images``: a report row (``status`` says why when not scored) and,
    when scored, which images it classified correctly (boolean, by image id). ``test_tiles``: each held-out
    image is scored with its tiles (:func:`clothscope.classify.loocv.loocv`)."""
    try:
        frame, columns = joined_features(feature_set, tables, images)
        pooled = feature_set.pooled()
        voting = pooled is not None and pooled[1]
        tiles = joined_tiles({source: tables[source] for source in feature_set.sources}, tile_tables)
        result = loocv(frame, columns, reg, select_from=auto_candidates(columns, pooled[0]) if pooled else None,
                       subspace=subspace, tiles=tiles, test_tiles=test_tiles, vote=voting)
    except (KeyError, ValueError) as err:
        return _unscored_row(feature_set, str(err)), None
    counts = result.selected_counts()
    chosen = f"{'votes' if voting else 'folds chose'}: {counts}" if counts else ""
    right = result.right_by_image()
    return {**_unscored_row(feature_set, chosen), "status": "ok",
            "n_features": len(result.feature_columns), "n": result.n, "correct": result.correct, "accuracy": result.accuracy,
            "wilson_low": result.wilson_low, "wilson_high": result.wilson_high, "chance": result.chance_uniform}, right


def mcnemar_p(only_first: int, only_second: int) -> float:
    """Two-sided exact McNemar p-value of two classifiers scored on the same images.

    ``only_first`` and ``only_second`` count the images that only the first
    (only the second) classified correctly; images both got right or both got
    wrong say nothing about which is better. Without such images the p-value is 1.
    """
    if only_first < 0 or only_second < 0:
        raise ValueError(f"McNemar counts must be >= 0, got {only_first} and {only_second}")
    discordant = only_first + only_second
    return 1.0 if discordant == 0 else float(binomtest(only_first, discordant, 0.5).pvalue)


def discordant(first: pd.Series, second: pd.Series) -> tuple[int, int]:
    """Images only ``first`` got right, and only ``second`` (boolean Series by image id, on the images both hold)."""
    first, second = first.align(second, join="inner")
    return int((first & ~second).sum()), int((second & ~first).sum())


def best_photo_only(report: pd.DataFrame) -> pd.Series | None:
    """The scored photo-only row of ``report`` with the highest accuracy (ties: the first), or ``None``."""
    photo = report[(report["status"] == "ok") & report["photo_only"].astype(bool)]
    return None if photo.empty else photo.loc[photo["accuracy"].idxmax()]


def paired_with_best_photo(report: pd.DataFrame, hits: dict[str, pd.Series]) -> pd.DataFrame:
    """``report`` with each scored set paired, image by image, with the most accurate photo-only set.

    Adds ``photo_reference`` (that set), ``only_this_right`` and
    ``only_photo_right`` (images only this set, or only the photo set,
    classified correctly) and ``mcnemar_p`` (:func:`mcnemar_p`); empty for
    photo-only sets, for unscored sets, and when no photo-only set was scored.
    """
    out = report.assign(photo_reference="", only_this_right=pd.NA, only_photo_right=pd.NA, mcnemar_p=float("nan"))
    best = best_photo_only(out)
    if best is None:
        return out
    reference = str(best["feature_set"])
    for index, name in out["feature_set"].items():
        if name not in hits or bool(out.at[index, "photo_only"]):  # hits holds the scored sets only
            continue
        only_this, only_photo = discordant(hits[name], hits[reference])
        out.loc[index, ["photo_reference", "only_this_right", "only_photo_right", "mcnemar_p"]] = [
            reference, only_this, only_photo, mcnemar_p(only_this, only_photo)]
    return out


def compare_feature_sets(tables: dict[str, pd.DataFrame], reg: float | str, subspace: str,
                         tile_tables: dict[str, pd.DataFrame] | None = None,
                         feature_sets: tuple[FeatureSet, ...] = FEATURE_SETS, test_tiles: bool = False) -> pd.DataFrame:
    """Every one of ``feature_sets`` whose sources are all in ``tables``, scored on the images usable in all of them
    (each fold also trains on the tiles of its training images, :func:`joined_tiles`; with ``test_tiles`` the
    held-out image is scored with its own tiles too).

    ``truth`` is left out of the common image set when some of those images
    have no ground truth (a photo of the user's own); its sets then say so.
    """
    base = {s: t for s, t in tables.items() if s != "truth"}
    images = common_images(base) if base else common_images(tables)
    rows = []
    hits: dict[str, pd.Series] = {}
    for feature_set in feature_sets:
        if not all(source in tables for source in feature_set.sources):
            continue
        if "truth" in feature_set.sources and not set(images) <= set(map(str, usable(tables["truth"]).index)):
            rows.append(_unscored_row(feature_set, "some images have no ground truth"))
            continue
        row, right = score_feature_set(feature_set, tables, images, reg, subspace, tile_tables, test_tiles)
        rows.append(row)
        if right is not None:
            hits[feature_set.name] = right
    return paired_with_best_photo(pd.DataFrame(rows), hits)


def inverse_rendering_gain(report: pd.DataFrame, fitted_set: str) -> str:
    """One line: the fitted set's LOOCV accuracy against the best photo-only set's, in points."""
    fitted = report[(report["status"] == "ok") & (report["feature_set"] == fitted_set)]
    best = best_photo_only(report)
    if fitted.empty or best is None:
        return "Inverse rendering against the photo alone: not measured (both need scored feature sets)."
    gain = 100.0 * (float(fitted["accuracy"].iloc[0]) - float(best["accuracy"]))
    verb = "bought" if gain > 0 else ("cost" if gain < 0 else "changed nothing:")
    return (f"Inverse rendering {verb} {abs(gain):.1f} points over the photo alone: {fitted_set} "
            f"{100 * float(fitted['accuracy'].iloc[0]):.1f}% against the best photo-only set, {best['feature_set']}, "
            f"{100 * float(best['accuracy']):.1f}% (LOOCV, same {int(best['n'])} images){paired_clause(fitted.iloc[0])}. "
            f"{headroom_clause(float(best['accuracy']))}")


def headroom_clause(photo_accuracy: float) -> str:
    """The most any set could add over the best photo-only set on the same images (a fraction in, points out)."""
    return (f"The photo alone leaves {100.0 * (1.0 - photo_accuracy):.1f} points to a perfect score on these images: "
            "the most the fit could add here.")


def brdf_line(report: pd.DataFrame) -> str:
    """One line: what the fitted BRDF adds to the photo's structure descriptor (``photo_plus_brdf`` against
    ``structure_photo``, images right of the same images), or ``""`` where either was not scored."""
    scored = report[report["status"] == "ok"].set_index("feature_set")
    if not {"photo_plus_brdf", "structure_photo"} <= set(scored.index):
        return ""
    with_brdf, without = (int(scored.at[name, "correct"]) for name in ("photo_plus_brdf", "structure_photo"))
    return (f"The fitted BRDF beside the photo's structure descriptor: photo_plus_brdf {with_brdf}/{int(scored.at['photo_plus_brdf', 'n'])} "
            f"against structure_photo {without} ({with_brdf - without:+d} images).")


def relief_line(report: pd.DataFrame, fitted_set: str) -> str:
    """One line, where ground truth was scored: the fitted set against the true relief, or ``""``.

    It sets the true relief's structure descriptor alone (``structure_truth``, no BRDF)
    against ``fitted_set`` and the best photo-only set, and says which of three cases
    holds (:data:`RELIEF_MARGIN` apart): the fit keeps about what the relief holds; the
    photo does and the fit does not, so the fit loses it; or neither does, so the class
    is in the relief but these photos do not show enough of it to either.
    """
    scored = report[report["status"] == "ok"].set_index("feature_set")
    best = best_photo_only(report)
    if "structure_truth" not in scored.index or fitted_set not in scored.index or best is None:
        return ""
    relief, fitted, photo = (float(scored.at[name, "accuracy"]) for name in ("structure_truth", fitted_set, best["feature_set"]))
    if relief - fitted < RELIEF_MARGIN:
        verdict = "the fitted set keeps about as much of the class as the true relief holds"
    elif relief - photo < RELIEF_MARGIN:
        verdict = "the photo alone keeps about as much as the true relief and the fitted set does not, so the fit loses it"
    else:
        verdict = ("the class is in the relief, but neither the photo's luminance nor the fitted relief keeps enough of it: "
                   "the limit is what these photos show of the relief and what the fit recovers, not the descriptor")
    return (f"Against the true relief: its structure descriptor alone (no BRDF) scores {100 * relief:.1f}%, "
            f"{fitted_set} {100 * fitted:.1f}% and the photo's {best['feature_set']} {100 * photo:.1f}%; {verdict}.")


def _paired_counts(row: pd.Series) -> tuple[int, int, float] | None:
    """``(only_this_right, only_photo_right, mcnemar_p)`` of a :func:`paired_with_best_photo` row; ``None`` if unpaired."""
    try:
        counts = int(row["only_this_right"]), int(row["only_photo_right"]), float(row["mcnemar_p"])
    except (KeyError, TypeError, ValueError):
        return None
    return counts if math.isfinite(counts[2]) else None


def paired_clause(row: pd.Series) -> str:
    """``; image by image, only <set> was right on a ...`` for a paired report row, or ``""`` for an unpaired one."""
    paired = _paired_counts(row)
    if paired is None:
        return ""
    only_this, only_photo, p = paired
    return (f"; image by image, only {row['feature_set']} was right on {only_this} and only the photo's set on {only_photo} "
            f"(exact McNemar p = {p:.2g}{', not significant at the 5% level' if p >= 0.05 else ''})")


def _paired_cell(row: pd.Series) -> str:
    """The report's pairing with the best photo-only set: ``+a / -b, p = ...``, or ``-``."""
    paired = _paired_counts(row)
    return "-" if paired is None else f"+{paired[0]} / -{paired[1]}, p = {paired[2]:.2g}"


def _percent(value: float) -> str:
    return f"{100.0 * value:.1f}%" if math.isfinite(value) else "-"


def report_markdown(report: pd.DataFrame, gain_line: str, sources: list[str], subspace: str, relief: str = "",
                    scale: str = "") -> str:
    """The Markdown of ``feature_sets.md`` (``relief``: :func:`relief_line`, after the gain line where not empty;
    ``scale``: :func:`~clothscope.prepare.rejections.thread_scale_line`, after it where not empty; then
    :func:`brdf_line` where both its sets were scored)."""
    brdf = brdf_line(report)
    lines = ["# Feature sets side by side", "",
             f"LOOCV QDA (the classifier of record, Ledoit-Wolf shrinkage"
             f"{', in the discriminant subspace of each fold' if subspace == 'discriminant' else ''}) on the same labelled images, from the "
             f"sources {', '.join(sources)}. 95% Wilson intervals; chance is 1 / number of classes.", "",
             gain_line, "", *([relief, ""] if relief else []), *([scale, ""] if scale else []), *([brdf, ""] if brdf else []),
             "The column 'against the best photo' pairs a set with the most accurate photo-only set on the same "
             "images: +a / -b counts the images only this set (only the photo's set) got right, and p is the exact "
             "McNemar test of that split (p >= 0.05: not significant at the 5% level on these images).", "",
             "| feature set | what | features | correct | accuracy | 95% interval | chance | against the best photo | note |",
             "|---|---|---|---|---|---|---|---|---|"]
    for _, row in report.iterrows():
        if row["status"] != "ok":
            lines.append(f"| {row['feature_set']} | {row['description']} | - | - | {row['status']} | - | - | - | {row['reason']} |")
            continue
        lines.append(f"| {row['feature_set']} | {row['description']} | {row['n_features']} | {row['correct']}/{row['n']} | "
                     f"{_percent(row['accuracy'])} | {_percent(row['wilson_low'])}-{_percent(row['wilson_high'])} | "
                     f"{_percent(row['chance'])} | {_paired_cell(row)} | {row['reason'] if isinstance(row['reason'], str) else ''} |")
    lines += ["", "Features are standardised and constant columns dropped inside each fold; no setting of the "
              "descriptor or the classifier is chosen by these scores in the workflow (see docs/design.md for how "
              "the descriptor's defaults were chosen, and on which images)."]
    return "\n".join(lines) + "\n"


def feature_sets_job(table_paths: dict[str, str], reg: float | str, subspace: str, fitted_set: str,
                     md_path: str | os.PathLike[str], csv_path: str | os.PathLike[str], log: object = None,
                     tile_paths: dict[str, str] | None = None, test_tiles: bool = False,
                     prepared_path: str | os.PathLike[str] | None = None) -> pd.DataFrame:
    """The ``feature_sets`` rule: read each source's feature table (and tile table), compare, write Markdown and CSV
    (``test_tiles``: :func:`compare_feature_sets`; ``prepared_path``: ``prepared.tsv``, whose thread scales the
    Markdown sums up)."""
    tables = {source: pd.read_parquet(path) for source, path in table_paths.items()}
    tile_tables = {source: pd.read_parquet(path) for source, path in (tile_paths or {}).items()}
    report = compare_feature_sets(tables, reg, subspace, tile_tables, test_tiles=test_tiles)
    line = inverse_rendering_gain(report, fitted_set)
    write_text(Path(csv_path), report.to_csv(index=False, lineterminator="\n", float_format="%.6f"))
    relief = relief_line(report, fitted_set)
    scale = thread_scale_line(pd.read_csv(prepared_path, sep="\t", dtype={"period_band_px": str})) if prepared_path else ""
    write_text(Path(md_path), report_markdown(report, line, list(tables), subspace, relief, scale))
    if log is not None:
        for text in (line, relief, scale):
            if text:
                log.info("%s", text)
    return report


def joined_table(tables: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """Every image of the first table, with each source's feature columns as ``<source>.<column>``.

    An image is ``ok`` only where it is ok in every source; otherwise it takes
    the first failing source's status and reason (prefixed with the source).
    """
    sources = list(tables)
    first = tables[sources[0]]
    frame = first[[c for c in JOINED_PROVENANCE if c in first.columns]].reset_index(drop=True).copy()
    for source in sources:
        table = tables[source].set_index("image_id").reindex(frame["image_id"])
        columns = list(dict.fromkeys(c for g in JOINED_GROUPS for c in group_columns(g, table.columns)))
        values = table[columns].fillna(0.0).astype(float).set_axis([f"{source}.{c}" for c in columns], axis=1)
        frame = pd.concat([frame, values.reset_index(drop=True)], axis=1)
        status = table["status"].fillna("missing").to_numpy()
        failing = (frame["status"].to_numpy() == STATUS_OK) & (status != STATUS_OK)
        reasons = table["reason"].fillna(f"no {source} row").astype(str).to_numpy()
        frame.loc[failing, "status"] = status[failing]
        frame.loc[failing, "reason"] = [f"{source}: {r}" for r in reasons[failing]]
    return frame


def joined_tiles(tables: dict[str, pd.DataFrame], tile_tables: dict[str, pd.DataFrame] | None) -> pd.DataFrame | None:
    """Tile rows laid out as :func:`joined_table` of ``tables``: each tile is its image's joined row with every
    source's :data:`~clothscope.features.structure.TILE_FEATURES` taken from that source's tile of the same index.

    ``None`` when some source has no tiles (no tile table, or ``features.tiles.grid`` 0): the classifier
    then trains on whole images only.
    """
    if not tile_tables or any(tile_tables.get(source) is None or tile_tables[source].empty for source in tables):
        return None
    images = joined_table(tables).assign(image_id=lambda t: t["image_id"].astype(str)).set_index("image_id")
    keys = None
    for source in tables:
        tiles = tile_tables[source].assign(image_id=lambda t: t["image_id"].astype(str))
        columns = [c for c in TILE_FEATURES if c in tiles.columns]
        part = tiles[["image_id", "tile", *columns]].rename(columns={c: f"{source}.{c}" for c in columns})
        keys = part if keys is None else keys.merge(part, on=["image_id", "tile"], how="inner")
    keys = keys[keys["image_id"].isin(images.index)].reset_index(drop=True)
    if keys.empty:
        return None
    rows = images.loc[keys["image_id"]].reset_index()
    described = keys.drop(columns=["image_id"])
    return pd.concat([rows.drop(columns=described.columns.intersection(rows.columns)), described], axis=1)[
        [*rows.columns, "tile"]]


def classifier_candidates(feature_set: str, maps: str, columns: list[str] | pd.Index) -> dict[str, list[str]]:
    """Column sets of a joined table for one ``classify.feature_set`` (several for ``auto`` and ``vote``).

    ``maps`` is the classifier's own source (``fitted``, ``truth`` or ``photo``);
    the photo sets need a ``photo`` source beside it.
    """
    sets = auto_candidates(columns, maps)
    if maps != "photo" and any(str(n).startswith("photo.") for n in columns):
        sets["photo_structure"] = source_columns(columns, "photo", "structure")
        sets["plus_photo"] = sets["structure_brdf"] + sets["photo_structure"]
        sets |= {name: source_columns(columns, "photo", group) for name, group in PHOTO_GROUPS.items()}
        sets["photo_structure_brdf"] = sets["photo_structure"] + source_columns(columns, maps, "brdf")
    if feature_set in CANDIDATE_GROUPS:
        return sets
    if feature_set not in sets:
        raise ValueError(f"feature set {feature_set!r} needs sources this classifier does not have (it reads {maps}"
                         f"{' and photo' if 'photo_structure' in sets else ''})")
    return {feature_set: sets[feature_set]}
