"""Write ``docs/results.md``: the measured figures of the workflow and the benchmarks, read from their output files.

    .venv/bin/python workflow/benchmarks/results_doc.py [--results results] [--out docs/results.md] [--keep-earlier]

Every section names the file its figures come from and the date that file was
written; where the file does not exist the section says ``not measured: run
<command>`` instead. Nothing is measured here: figures are copied from the
reports, and the only arithmetic is the median and maximum of Snakemake's
per-job benchmark files. Relative paths are taken from the repository root.
With ``--keep-earlier`` a section whose file is missing on this machine keeps
the measured text of the page being replaced (its source line names the file
and the date it was written), so one new benchmark does not erase the others;
with it or ``--only``, the sections that compare runs (runs, classifier of
record, feature sets, fit accuracy) keep the rows and columns of runs whose
reports are not on this machine in the same way.
"""
from __future__ import annotations

import argparse
import csv
import json
import re
import statistics
from collections import defaultdict
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from harness import ROOT, SUBSET, declared_resources, shown

from clothscope.core.atomic import write_text
from clothscope.core.config import schema_defaults

THIS_COMMAND = ".venv/bin/python workflow/benchmarks/results_doc.py"
#: The three-weave set's photos timed from prepare to the normal map: the first two of each class.
FIELD_TIMED = "broadcloth_00,broadcloth_01,satin_00,satin_01,twill_00,twill_01"


@dataclass(frozen=True)
class Run:
    """One workflow run (a results folder) whose reports are compared with the others'."""

    label: str
    folder: Path
    sheet: Path
    command: str
    truth: bool = True  # False for photos without ground truth (no fit-accuracy report)


@dataclass(frozen=True)
class BenchmarkReport:
    """A Markdown report written by a benchmark script, looked for at ``candidates`` (first found wins)."""

    title: str
    candidates: tuple[str, ...]
    command: str


#: How the mixed dye layout's runs were made: the BEFORE runs with the hard layout of then, the AFTER with mixed.
MIXED_LAYOUT_NOTE = ("(measured on 2026-12-04 with `--rerun` of an overlay giving `fit: {normals: {layout_mixing: mixed}}`, "
                     "the default since; each BEFORE run made with what `config/overlays/layout_hard.yaml` gives)")
#: The five sets refeatured with ``features.period_source: auto`` (label, folder under results/, sheet folder).
PERIOD_AUTO_SETS = (("three weaves 1144", "weaves_1144", "photos"), ("three weaves 1145", "weaves_1145", "photos"),
                    ("microscope-like weaves 1148", "microscope_1148", "photos"),
                    ("microscope-like weaves 1149", "microscope_1149", "field"),
                    ("microscope-like weaves 1150", "microscope_1150", "field"))
#: The sets of ``descriptor_candidates.py``, one report per kind of capture (title, report suffix, folders under results/).
DESCRIPTOR_SETS = (("four phone-lit weave sets", "weaves", ("weaves_1140", "weaves_1143", "weaves_1144", "weaves_1145")),
                   ("four microscope-like sets", "microscope",
                    ("microscope", "microscope_1148", "microscope_1149", "microscope_1150")))
#: The benchmark that refeatures a run with the config's defaults (period_source auto), fits reused.
PERIOD_AUTO_RERUN = "setting_gain.py --rerun config/config.yaml --drop features/photo --drop features/fitted"


def period_auto_pair(results: str, folder: str, images: str) -> str:
    """The ``BEFORE:AFTER:SHEET`` argument of :data:`PERIOD_AUTO_RERUN` for one of :data:`PERIOD_AUTO_SETS`."""
    return f"{results}/{folder}/run:{results}/{folder}_auto/run:{results}/{folder}/{images}/samples.tsv"


def written_on(path: Path) -> str:
    """The UTC date ``path`` was last written, ``YYYY-MM-DD``."""
    return datetime.fromtimestamp(path.stat().st_mtime, tz=timezone.utc).strftime("%Y-%m-%d")


def source_entry(path: Path) -> str:
    """A file named with the date it was written: ```path` (YYYY-MM-DD)``."""
    return f"`{shown(path)}` ({written_on(path)})"


def source_note(paths: list[Path]) -> str:
    """One line naming the files a section's figures come from, with their dates."""
    return source_line([source_entry(path) for path in paths])


def source_line(entries: list[str]) -> str:
    """The ``Source:`` line of a section from its entries (:func:`source_entry`)."""
    return "Source: " + ", ".join(entries) + "."


def earlier_sources(section: str, run: Run) -> list[str]:
    """The entries of an earlier section's ``Source:`` line that name files of ``run``'s reports."""
    line = next((line for line in section.splitlines() if line.startswith("Source: ")), "")
    prefix = f"`{shown(run.folder / 'reports')}/"
    return [entry for entry in re.findall(r"`[^`]+` \([^)]*\)", line) if entry.startswith(prefix)]


def earlier_rows(section: str, label: str) -> list[list[str]]:
    """The rows of an earlier section's first table whose first cell is ``label`` (a run's row kept from that page)."""
    tables = markdown_tables(section)
    return [row for row in tables[0][1:] if row and row[0] == label] if tables else []


def earlier_column(section: str, label: str, fixed: int) -> dict[tuple[str, ...], str]:
    """A run's column of an earlier section's first table, whose first ``fixed`` columns name the row:
    those cells -> the cell under ``label`` (empty when no column is headed ``label``)."""
    tables = markdown_tables(section)
    if not tables or label not in tables[0][0][fixed:]:
        return {}
    column = tables[0][0].index(label, fixed)
    return {tuple(row[:fixed]): row[column] for row in tables[0][1:] if len(row) > column}


def not_measured(command: str) -> str:
    """The line a section shows in place of figures whose file does not exist."""
    return f"not measured: run `{command}`"


def workflow_runs(results: Path) -> list[Run]:
    """The design run, the held-out runs, the capture-realistic field sets and the colour-texture experiment, with their commands."""
    r = shown(results)
    own_folder = "" if r == "results" else f" --config results={r}"
    design = ".venv/bin/snakemake --cores 2" + own_folder
    holdout = (f".venv/bin/snakemake --cores 2 holdout_set{own_folder} && .venv/bin/snakemake --cores 2 "
               f"--config samples={r}/holdout/samples.tsv results={r}/holdout/run")
    field = (f".venv/bin/snakemake --cores 2 field_set{own_folder} && .venv/bin/snakemake --cores 2 "
             f"--config samples={r}/field/samples.tsv results={r}/field/run")
    albedo = (".venv/bin/snakemake --cores 2 --configfile config/config.yaml config/overlays/colour_texture.yaml "
              f"--config results={r}/exp_albedo")
    default_sheet = ROOT / "config" / "samples.tsv"

    def period_auto_run(label: str, folder: str, images: str) -> Run:
        """``results/<folder>/run`` (made with ``features.period_source: field``, the default of then) refeatured with
        ``auto`` into ``results/<folder>_auto/run``, its fits reused."""
        command = f".venv/bin/python workflow/benchmarks/{PERIOD_AUTO_RERUN} {period_auto_pair(r, folder, images)}"
        return Run(label, results / f"{folder}_auto" / "run", results / folder / images / "samples.tsv", command)

    def rendered_run(label: str, folder: str, images: str, overlay: str | None = None) -> Run:
        """A set rendered by the ``<images>_set`` target (holdout or field) with ``config/overlays/<overlay>.yaml``
        (default: ``<folder>.yaml``) into ``results/<folder>/<images>/`` and run into ``results/<folder>/run``."""
        command = (f".venv/bin/snakemake --cores 2 {images}_set --configfile config/config.yaml "
                   f"config/overlays/{overlay or folder}.yaml && .venv/bin/snakemake --cores 2 "
                   f"--config samples={r}/{folder}/{images}/samples.tsv results={r}/{folder}/run")
        return Run(label, results / folder / "run", results / folder / images / "samples.tsv", command)

    def mixed_layout_run(label: str, folder: str, images: str) -> Run:
        """``results/<folder>/run`` (made with the hard dye layout, the default of then) with its normal maps refitted
        with ``fit.normals.layout_mixing: mixed`` into ``results/<folder>/run_mixed``, its other fits reused."""
        command = (f".venv/bin/python workflow/benchmarks/setting_gain.py --rerun config/config.yaml --drop 'fit/*/normals' "
                   f"{r}/{folder}/run:{r}/{folder}/run_mixed:{r}/{folder}/{images}/samples.tsv (`run` made with "
                   "config/overlays/layout_hard.yaml)")
        return Run(label, results / folder / "run_mixed", results / folder / images / "samples.tsv", command)

    def fitted_field_run(label: str, folder: str, run: str = "run_axes") -> Run:
        """A field set rendered by ``config/overlays/<folder>.yaml`` (whose ``run`` holds only the photo's features)
        run whole, fits included, with the defaults of its day into ``results/<folder>/<run>``."""
        command = (f".venv/bin/snakemake --cores 2 field_set --configfile config/config.yaml config/overlays/{folder}.yaml "
                   f"&& .venv/bin/snakemake --cores 2 --config samples={r}/{folder}/field/samples.tsv "
                   f"results={r}/{folder}/{run}")
        return Run(label, results / folder / run, results / folder / "field" / "samples.tsv", command)

    def real_run(label: str, half: str, run: str = "run", overlay: str | None = None) -> Run:
        """Set ``a`` to ``g`` of the real photos (``real_photos.py``) run into ``results/real/<half>/<run>``,
        with the defaults or with ``config/overlays/<overlay>.yaml``."""
        overlay_files = f" --configfile config/config.yaml config/overlays/{overlay}.yaml" if overlay else ""
        command = (f".venv/bin/python workflow/benchmarks/real_photos.py --source <clone>/Images --out {r}/real "
                   "--sets a b c d e f g --last-short && "
                   f".venv/bin/snakemake --cores 2{overlay_files} --config samples={r}/real/{half}/samples.tsv "
                   f"results={r}/real/{half}/{run}")
        return Run(label, results / "real" / half / run, results / "real" / half / "samples.tsv", command, truth=False)

    return [
        Run("design", results, default_sheet, design),
        Run("held-out", results / "holdout" / "run", results / "holdout" / "samples.tsv", holdout),
        rendered_run("held-out 1126", "confirm_1126", "holdout"),
        Run("field", results / "field" / "run", results / "field" / "samples.tsv", field),
        rendered_run("three weaves", "weaves", "field", "field_weaves"),
        rendered_run("three weaves, fresh", "weaves_fresh", "field"),
        rendered_run("three weaves, fourth", "weaves_period", "field"),
        rendered_run("microscope-like weaves", "microscope", "field"),
        rendered_run("microscope-like weaves, second", "microscope_confirm", "field"),
        rendered_run("held-out 1132", "holdout_1132", "holdout"),
        rendered_run("three weaves, fifth", "weaves_1131", "field"),
        rendered_run("microscope-like weaves, third", "microscope_1130", "field"),
        rendered_run("held-out 1135", "holdout_1135", "holdout"),
        rendered_run("three weaves, sixth", "weaves_1134", "field"),
        rendered_run("microscope-like weaves, fourth", "microscope_1133", "field"),
        rendered_run("three weaves, seventh", "weaves_1140", "field"),
        rendered_run("microscope-like weaves, fifth", "microscope_1141", "field"),
        rendered_run("microscope-like weaves 1142", "microscope_1142", "field"),
        rendered_run("three weaves 1143", "weaves_1143", "field"),
        rendered_run("three weaves 1144", "weaves_1144", "field"),
        rendered_run("three weaves 1145", "weaves_1145", "field"),
        rendered_run("held-out 1147", "holdout_1147", "holdout"),
        rendered_run("microscope-like weaves 1148", "microscope_1148", "field"),
        rendered_run("microscope-like weaves 1149", "microscope_1149", "field"),
        rendered_run("microscope-like weaves 1150", "microscope_1150", "field"),
        rendered_run("held-out 1151", "holdout_1151", "holdout"),
        rendered_run("held-out 1158", "holdout_1158", "holdout"),
        rendered_run("held-out 1162", "holdout_1162", "holdout"),
        rendered_run("held-out 1164", "holdout_1164", "holdout"),
        rendered_run("held-out 1166", "holdout_1166", "holdout"),
        rendered_run("held-out 1167", "holdout_1167", "holdout"),
        rendered_run("held-out 1169", "holdout_1169", "holdout"),
        rendered_run("held-out 1171", "holdout_1171", "holdout"),
        rendered_run("held-out 1175", "holdout_1175", "holdout"),
        rendered_run("held-out 1176", "holdout_1176", "holdout"),
        rendered_run("held-out 1178", "holdout_1178", "holdout"),
        rendered_run("held-out 1207", "holdout_1207", "holdout"),
        fitted_field_run("microscope-like weaves 1156, fitted", "microscope_1156"),
        fitted_field_run("three weaves 1157, fitted", "weaves_1157"),
        fitted_field_run("microscope-like weaves 1159, fitted", "microscope_1159", "run_axes_harmonic"),
        fitted_field_run("three weaves 1160, fitted", "weaves_1160", "run_axes_harmonic"),
        fitted_field_run("three weaves 1161, fitted", "weaves_1161", "run"),
        fitted_field_run("three weaves 1163, fitted", "weaves_1163", "run"),
        fitted_field_run("microscope-like weaves 1165, fitted", "microscope_1165", "run"),
        fitted_field_run("microscope-like weaves 1168, fitted", "microscope_1168", "run"),
        fitted_field_run("microscope-like weaves 1170, fitted", "microscope_1170", "run"),
        fitted_field_run("microscope-like weaves 1172, fitted", "microscope_1172", "run"),
        fitted_field_run("microscope-like weaves 1173, fitted", "microscope_1173", "run"),
        fitted_field_run("microscope-like weaves 1174, fitted", "microscope_1174", "run"),
        fitted_field_run("microscope-like weaves 1177, fitted", "microscope_1177", "run"),
        fitted_field_run("three weaves 1205, fitted (hard dye layout)", "weaves_1205", "run"),
        fitted_field_run("microscope-like weaves 1208, fitted", "microscope_1208", "run"),
        fitted_field_run("microscope-like weaves 1209, fitted", "microscope_1209", "run"),
        mixed_layout_run("held-out 1178, mixed dye layout", "holdout_1178", "holdout"),
        mixed_layout_run("three weaves 1163, mixed dye layout", "weaves_1163", "field"),
        mixed_layout_run("three weaves 1205, mixed dye layout", "weaves_1205", "field"),
        *(period_auto_run(f"{label}, period auto", folder, images) for label, folder, images in PERIOD_AUTO_SETS),
        Run("colour texture", results / "exp_albedo", default_sheet, albedo),
        real_run("real photos, design half", "a"),
        real_run("real photos, design half, magnified up to 2x", "a", "run_up2", "upsample_2"),
        real_run("real photos, confirmation half", "b"),
        real_run("real photos, confirmation half, magnified up to 2x", "b", "run_up2", "upsample_2"),
        real_run("real photos, third set", "c"),
        real_run("real photos, fourth set", "d"),
        real_run("real photos, fifth set (never looked at before its run)", "e"),
        real_run("real photos, sixth set (never looked at before its run)", "f"),
        real_run("real photos, seventh set (never looked at before its run)", "g"),
    ]


def read_csv_rows(path: Path, delimiter: str = ",") -> list[dict[str, str]]:
    """Rows of a CSV or TSV file as dictionaries keyed by its header."""
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle, delimiter=delimiter))


def markdown_tables(text: str) -> list[list[list[str]]]:
    """Every pipe table in ``text``: a list of rows (header first, separator dropped), each a list of cells."""
    tables: list[list[list[str]]] = []
    current: list[list[str]] = []
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
            if not all(set(cell) <= set("-: ") for cell in cells):
                current.append(cells)
        elif current:
            tables.append(current)
            current = []
    return tables


def lines_starting(path: Path, prefix: str) -> list[str]:
    """The lines of a text file that start with ``prefix``."""
    return [line for line in path.read_text(encoding="utf-8").splitlines() if line.startswith(prefix)]


def render_table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown pipe table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def embedded_markdown(path: Path) -> str:
    """A report's Markdown without its title line, its headings moved two levels down to sit under this page's."""
    lines = path.read_text(encoding="utf-8").strip().splitlines()
    if lines and lines[0].startswith("# "):
        lines = lines[1:]
    return "\n".join("##" + line if line.startswith("#") else line for line in lines).strip()


def percent(fraction: str | float) -> str:
    """A fraction written as a percentage with one decimal."""
    return f"{100 * float(fraction):.1f}%"


def missing_runs(runs: list[Run], measured: list[Run]) -> list[str]:
    """One block with a not-measured line per run that lacks a section's file (empty when none does)."""
    lines = [f"- {run.label}: {not_measured(run.command)}" for run in runs if run not in measured]
    return ["\n".join(lines)] if lines else []


def runs_section(runs: list[Run], earlier: str = "") -> str:
    """Which runs the page compares: folder, sample sheet, number of images and the sheet's ``source`` values.

    A run whose files are not here keeps its row of ``earlier`` (the page being replaced), if that has one.
    """
    rows = []
    for run in runs:
        if not (run.folder / "reports").is_dir() or not run.sheet.exists():
            kept = [row for row in earlier_rows(earlier, run.label) if not row[-1].startswith("not measured")]
            rows += kept or [[run.label, f"`{shown(run.folder)}`", f"`{shown(run.sheet)}`", "-", not_measured(run.command)]]
            continue
        sheet = read_csv_rows(run.sheet, "\t")
        sources = sorted({row.get("source", "") for row in sheet} - {""})
        rows.append([run.label, f"`{shown(run.folder)}`", f"`{shown(run.sheet)}`", str(len(sheet)),
                     ", ".join(sources) or "-"])
    text = ("The *design* set is the embedded one: the descriptor's defaults and the classifier's options were chosen "
            "while looking at it, so its figures are optimistic. The *held-out* set was rendered from another seed "
            "after those choices; its figures are the ones to quote. The *colour texture* run is the design set with "
            "`fit.normals.albedo_weight: 0.05`.\n\n")
    return "## Runs\n\n" + text + render_table(["run", "results folder", "sample sheet", "images", "source"], rows)


def model_feature_set(record_path: Path) -> str:
    """The feature set a saved model reads (``chosen_set`` in its ``model.json``), or ``-``."""
    if not record_path.exists():
        return "-"
    record = json.loads(record_path.read_text(encoding="utf-8"))
    return str(record.get("metadata", {}).get("chosen_set") or "-")


def classifier_row(run: Run, accuracy_path: Path) -> list[str]:
    """One table row from a run's ``reports/<source>/accuracy.json`` and the model beside it."""
    source = accuracy_path.parent.name
    result = json.loads(accuracy_path.read_text(encoding="utf-8"))
    model_set = model_feature_set(run.folder / "models" / source / "model.json")
    if result.get("status") == "not run":
        return [run.label, source, "-", "not run: " + str(result.get("reason", "")), "-", "-", "-", model_set]
    folds = sorted(result.get("selected_feature_sets", {}).items(), key=lambda item: -item[1])
    return [run.label, source, f"{result['correct']}/{result['n']}", percent(result["accuracy"]),
            f"{percent(result['wilson_low'])}-{percent(result['wilson_high'])}", percent(result["chance_uniform"]),
            ", ".join(f"{name} {count}" for name, count in folds) or "-", model_set]


def classifier_section(runs: list[Run], earlier: str = "") -> str:
    """The classifier of record's LOOCV accuracy per run and source (``reports/<source>/accuracy.json``).

    A run whose reports are not here keeps its rows and source entries of ``earlier`` (the page being replaced).
    """
    found = {run: sorted((run.folder / "reports").glob("*/accuracy.json")) for run in runs}
    rows, entries, measured = [], [], []
    for run in runs:
        kept = [] if found[run] else earlier_rows(earlier, run.label)
        if found[run]:
            rows += [classifier_row(run, path) for path in found[run]]
            entries += [source_entry(path) for path in found[run]]
        elif kept:
            rows += kept
            entries += earlier_sources(earlier, run)
        if found[run] or kept:
            measured.append(run)
    parts = ["## Classifier of record (LOOCV)"]
    if measured:
        parts += [source_line(entries), render_table(["run", "source", "correct", "accuracy", "95% Wilson", "chance",
                                                      "sets the folds chose", "model for new photos uses"], rows),
                  "The last column is read from `models/<source>/model.json` beside the reports; `-` where that "
                  "run has no such record."]
    parts += missing_runs(runs, measured)
    return "\n\n".join(parts)


def feature_sets_section(runs: list[Run], earlier: str = "") -> str:
    """Every feature set's LOOCV accuracy, one column per run (``reports/feature_sets.csv``).

    A run whose report is not here keeps its column, headline and source entry of ``earlier`` (the page being replaced).
    """
    columns: dict[str, dict[str, str]] = {}
    names: dict[str, str] = {}
    entries, headlines, measured = [], [], []
    for run in runs:
        path = run.folder / "reports" / "feature_sets.csv"
        if path.exists():
            table = read_csv_rows(path)
            for row in table:
                names.setdefault(f"`{row['feature_set']}`", row["description"])
            columns[run.label] = {f"`{row['feature_set']}`": f"{percent(row['accuracy'])} ({row['correct']}/{row['n']})"
                                  if row["status"] == "ok" else "-" for row in table}
            entries.append(source_entry(path))
            headlines += [f"- {run.label}: {line}" for line in lines_starting(path.with_suffix(".md"), "Inverse rendering")]
        elif kept := earlier_column(earlier, run.label, fixed=2):
            for name, description in kept:
                names.setdefault(name, description)
            columns[run.label] = {name: cell for (name, _), cell in kept.items()}
            entries += earlier_sources(earlier, run)
            headlines += [line for line in earlier.splitlines() if line.startswith(f"- {run.label}: Inverse rendering")]
        else:
            continue
        measured.append(run)
    parts = ["## Feature sets side by side"]
    if measured:
        rows = [[name, description, *(columns[run.label].get(name, "-") for run in measured)]
                for name, description in names.items()]
        parts += [source_line(entries), "What the inverse rendering bought over the photo alone:\n\n" + "\n".join(headlines),
                  render_table(["feature set", "what", *(run.label for run in measured)], rows)]
    parts += missing_runs(runs, measured)
    return "\n\n".join(parts)


def fit_accuracy_section(runs: list[Run], earlier: str = "") -> str:
    """The inverse renderer's errors against the ground truth, one column per run, then the design run per class.

    A run whose report is not here keeps its column, image count and source entry of ``earlier`` (the page being replaced).
    """
    keys: list[tuple[str, ...]] = []
    columns: dict[str, dict[tuple[str, ...], str]] = {}
    entries, counts, measured, here = [], [], [], []
    runs = [run for run in runs if run.truth]
    for run in runs:
        path = run.folder / "reports" / "fit_accuracy.md"
        if path.exists():
            columns[run.label] = {(metric, statistic, target): value
                                  for metric, statistic, value, target, *_ in markdown_tables(path.read_text(encoding="utf-8"))[0][1:]}
            entries.append(source_entry(path))
            counts += [f"- {run.label}: {line}" for line in lines_starting(path, "") if line.endswith("images fitted.")]
            here.append((run, path))
        elif kept := earlier_column(earlier, run.label, fixed=3):
            columns[run.label] = kept
            entries += earlier_sources(earlier, run)
            counts += [line for line in earlier.splitlines() if line.startswith(f"- {run.label}: ") and line.endswith("images fitted.")]
        else:
            continue
        measured.append(run)
        keys += [key for key in columns[run.label] if key not in keys]
    parts = ["## Inverse renderer against the ground truth"]
    if measured:
        rows = [[*key, *(columns[run.label].get(key, "-") for run in measured)] for key in keys]
        parts += [source_line(entries), "\n".join(counts),
                  render_table(["metric", "statistic", "target", *(run.label for run in measured)], rows),
                  "`total_s` is the sum of the three fit stages' wall-clock seconds per image, with two images "
                  "fitting side by side on the machine that ran them (see the rule times below)."]
        per_class = markdown_tables(here[0][1].read_text(encoding="utf-8")) if here else []
        if len(per_class) > 1:
            parts += [f"Medians per class, {here[0][0].label} run:", render_table(per_class[1][0], per_class[1][1:])]
    parts += missing_runs(runs, measured)
    return "\n\n".join(parts)


def rule_of(tsv: Path, benchmarks: Path) -> str:
    """The rule a benchmark file belongs to: its folder under ``benchmarks/``, at most two levels (``features/fitted``)."""
    return "/".join(tsv.parent.relative_to(benchmarks).parts[:2])


def headroom(requested: float | str, measured: list[float], scale: float = 1.0) -> str:
    """A request beside the largest measured value: ``"2000 (7.9x)"``; ``"-"`` with nothing to compare."""
    if isinstance(requested, str) or not measured or max(measured) <= 0:
        return str(requested) if isinstance(requested, str) else f"{requested:.0f}"
    return f"{requested:.0f} ({requested * scale / max(measured):.1f}x)"


def rule_times_table(benchmarks: Path, declared: dict[str, dict[str, float | str]]) -> str:
    """Median and maximum seconds and peak memory per rule over Snakemake's benchmark files in ``benchmarks``,
    beside each rule's ``mem_mb`` and ``runtime`` request (``declared``) and its headroom over the largest job."""
    seconds: dict[str, list[float]] = defaultdict(list)
    memory: dict[str, list[float]] = defaultdict(list)
    for tsv in sorted(benchmarks.rglob("*.tsv")):
        for row in read_csv_rows(tsv, "\t"):
            seconds[rule_of(tsv, benchmarks)].append(float(row["s"]))
            if row.get("max_rss", "NA") not in ("NA", "-", ""):
                memory[rule_of(tsv, benchmarks)].append(float(row["max_rss"]))
    rows = []
    for rule, values in sorted(seconds.items()):
        rss = memory.get(rule, [])
        request = declared.get(rule.split("/")[0], {})
        rows.append([f"`{rule}`", str(len(values)), f"{statistics.median(values):.1f}", f"{max(values):.1f}",
                     f"{statistics.median(rss):.0f}" if rss else "-", f"{max(rss):.0f}" if rss else "-",
                     headroom(request.get("mem_mb", "-"), rss), headroom(request.get("runtime", "-"), values, 60.0)])
    return render_table(["rule", "jobs", "median s", "max s", "median max RSS MB", "max RSS MB", "mem_mb (headroom)",
                         "runtime min (headroom)"], rows)


def headed_parts(text: str, marker: str) -> dict[str, str]:
    """Heading -> its part (heading line included, trailing space dropped) of each ``marker`` heading in ``text``."""
    parts = ("\n" + text).split(f"\n{marker} ")[1:]
    return {part.splitlines()[0]: f"{marker} " + part.rstrip() for part in parts}


def earlier_subsections(section: str) -> dict[str, str]:
    """Label -> text of each ``### `` subsection of an earlier page's section (the text under its heading)."""
    return {label: part.partition("\n")[2].strip() for label, part in headed_parts(section, "###").items()}


def rule_times_section(runs: list[Run], earlier: str = "") -> str:
    """Per-rule time and memory of each run, from ``<run>/benchmarks/**/*.tsv``, beside the rules' requests;
    a run whose files are not here keeps its table from ``earlier`` (the page's previous section), if it had one."""
    parts = ["## Time and memory per rule",
             "Wall-clock seconds and peak resident memory of each job, from Snakemake's `benchmark:` files, as "
             "measured on the machine and under the load of the run that wrote them (two jobs side by side on 2 "
             "cores by default). A rule missing from a run's table did not run in that folder. `mem_mb` and "
             "`runtime` are what each rule asks a cluster for with the default config today, and in brackets how "
             "many times the largest job of that run they are; `prepare` asks per photo, from its pixel count "
             "(\"prepare on large photos: time and peak memory\" below)."]
    declared, kept = declared_resources(), earlier_subsections(earlier)
    for run in runs:
        benchmarks = run.folder / "benchmarks"
        files = sorted(benchmarks.rglob("*.tsv")) if benchmarks.is_dir() else []
        parts.append(f"### {run.label}")
        if not files:
            previous = kept.get(run.label, "")
            parts.append(previous if previous.startswith("Source:") else not_measured(run.command))
            continue
        dates = sorted({written_on(path) for path in files})
        span = dates[0] if len(dates) == 1 else f"{dates[0]} to {dates[-1]}"
        parts += [f"Source: `{shown(benchmarks)}/**/*.tsv` ({len(files)} files, written {span}).",
                  rule_times_table(benchmarks, declared)]
    return "\n\n".join(parts)


def embedded_section(title: str, candidates: list[Path], command: str) -> str:
    """A report embedded as it is, from the first of ``candidates`` that exists, or the not-measured line."""
    found = [path for path in candidates if path.exists()]
    if not found:
        return f"## {title}\n\n{not_measured(command)}"
    return f"## {title}\n\n{source_note(found[:1])} Made by `{command}`.\n\n{embedded_markdown(found[0])}"


def benchmark_reports(results: Path) -> list[BenchmarkReport]:
    """The benchmark scripts' reports, with the command that writes each (see ``workflow/benchmarks/``)."""
    py = ".venv/bin/python workflow/benchmarks"
    return [
        BenchmarkReport("Structure descriptor settings, design and held-out", ("reports/structure_sweep.md",),
                        f"{py}/structure_sweep.py"),
        BenchmarkReport("The capture-realistic field set: generator draws and thread periods", ("bench/field_set.md",),
                        f"{py}/field_set.py"),
        BenchmarkReport("Thread periods on the field set's design images (seed 20261202)", ("bench/field_set_design.md",),
                        f"{py}/field_set.py --field results/field_design/field --run results/field_design/run "
                        "--name field_set_design"),
        BenchmarkReport("Thread periods on the three-weave set (seed 20261203)", ("bench/field_set_weaves.md",),
                        f"{py}/field_set.py --field results/weaves/field --run results/weaves/run --name field_set_weaves"),
        BenchmarkReport("Thread periods on a fresh three-weave set (seed 20261226)", ("bench/field_set_weaves_fresh.md",),
                        f"{py}/field_set.py --field results/weaves_fresh/field --run results/weaves_fresh/run "
                        "--name field_set_weaves_fresh"),
        BenchmarkReport("Thread periods on a fourth three-weave set (seed 20261227)", ("bench/field_set_weaves_period.md",),
                        f"{py}/field_set.py --field results/weaves_period/field --run results/weaves_period/run "
                        "--name field_set_weaves_period"),
        BenchmarkReport("Thread periods on the microscope-like weave set (seed 20261228)", ("bench/field_set_microscope.md",),
                        f"{py}/field_set.py --field results/microscope/field --run results/microscope/run "
                        "--name field_set_microscope"),
        BenchmarkReport("Thread periods on the second microscope-like weave set (seed 20261229)",
                        ("bench/field_set_microscope_confirm.md",),
                        f"{py}/field_set.py --field results/microscope_confirm/field --run results/microscope_confirm/run "
                        "--name field_set_microscope_confirm"),
        BenchmarkReport("Feature sets by capture, the two microscope-like weave sets pooled", ("bench/pooled_microscope.md",),
                        f"{py}/pooled_captures.py --set results/microscope/run results/microscope/field/samples.tsv "
                        "--set results/microscope_confirm/run results/microscope_confirm/field/samples.tsv "
                        "--each --name pooled_microscope"),
        BenchmarkReport("What an open weave's holes cost the fit", ("bench/open_weave/open_weave.md",),
                        f"{py}/open_weave.py"),
        BenchmarkReport("What an open weave's holes cost the fit, chiffon", ("bench/open_weave_chiffon/open_weave.md",),
                        f"{py}/open_weave.py --fabric chiffon"),
        BenchmarkReport("The light's azimuth: the fit, the falloff and the threads", ("bench/light_direction.md",),
                        f"{py}/light_direction.py"),
        BenchmarkReport("The light's azimuth on sets no choice looked at", ("bench/light_direction_confirm.md",),
                        f"{py}/light_direction.py --set results/weaves_fresh/run results/weaves_fresh/field/samples.tsv "
                        "--set results/weaves_period/run results/weaves_period/field/samples.tsv "
                        "--set results/confirm_1126/run results/confirm_1126/holdout/samples.tsv --name light_direction_confirm"),
        BenchmarkReport("Feature sets by capture, the design weave sets with the light placed by the threads",
                        ("bench/exp_threads_2sets.md",),
                        f"{py}/pooled_captures.py --set results/exp_threads/weaves results/weaves/field/samples.tsv "
                        "--set results/exp_threads/weaves_confirm results/weaves_confirm/field/samples.tsv --each --name exp_threads_2sets"),
        BenchmarkReport("Feature sets by capture, the four weave sets with the light placed by the threads",
                        ("bench/exp_threads_4sets.md",),
                        f"{py}/pooled_captures.py --set results/exp_threads/weaves results/weaves/field/samples.tsv "
                        "--set results/exp_threads/weaves_confirm results/weaves_confirm/field/samples.tsv "
                        "--set results/exp_threads/weaves_fresh results/weaves_fresh/field/samples.tsv "
                        "--set results/exp_threads/weaves_period results/weaves_period/field/samples.tsv --name exp_threads_4sets"),
        BenchmarkReport("Feature sets by capture, the design weave sets with the threads' light at strength 0.05",
                        ("bench/exp_threadsB_2sets.md",),
                        f"{py}/pooled_captures.py --set results/exp_threadsB/weaves results/weaves/field/samples.tsv "
                        "--set results/exp_threadsB/weaves_confirm results/weaves_confirm/field/samples.tsv --each "
                        "--name exp_threadsB_2sets"),
        BenchmarkReport("Feature sets by capture, the design weave sets (default fit)", ("bench/base_2sets.md",),
                        f"{py}/pooled_captures.py --set results/weaves/run results/weaves/field/samples.tsv "
                        "--set results/weaves_confirm/run results/weaves_confirm/field/samples.tsv --each --name base_2sets"),
        BenchmarkReport("Feature sets by capture, two fresh capture sets fitted with the current defaults",
                        ("bench/fitted_1156_1157.md",),
                        f"{py}/pooled_captures.py --set results/microscope_1156/run_axes "
                        "results/microscope_1156/field/samples.tsv --set results/weaves_1157/run_axes "
                        "results/weaves_1157/field/samples.tsv --each --name fitted_1156_1157"),
        BenchmarkReport("Thread periods on a fresh nine-class set (seed 20261207)", ("bench/field_set_confirm.md",),
                        f"{py}/field_set.py --field results/period_confirm/field --run results/period_confirm/run "
                        "--name field_set_confirm"),
        BenchmarkReport("A (1, 1) harmonic read as the thread period: stepping down to the threads", ("bench/period_harmonic.md",),
                        f"{py}/period_harmonic.py results/microscope/field results/microscope_1141/field "
                        "results/microscope_1148/field results/weaves/field results/weaves_1140/field results/weaves_1143/field "
                        "results/weaves_1144/field results/weaves_1145/field results/microscope_1149/field"),
        BenchmarkReport("A (1, 1) harmonic read as the thread period, on a fifth microscope-like set (after the rule)",
                        ("bench/period_harmonic_1150.md",),
                        f"{py}/period_harmonic.py results/microscope_1150/field --name period_harmonic_1150"),
        BenchmarkReport("What a perfect thread period would buy the photo's descriptor", ("bench/period_oracle.md",),
                        f"{py}/period_oracle.py "
                        + " ".join(f"--set results/{folder}/run results/{folder}/field" for _, folder, _ in PERIOD_AUTO_SETS)),
        BenchmarkReport("What a perfect thread period would buy the photo's descriptor, on three earlier sets",
                        ("bench/period_oracle_more.md",),
                        f"{py}/period_oracle.py --set results/microscope/run results/microscope/field "
                        "--set results/weaves_1140/run results/weaves_1140/field --set results/weaves_1143/run "
                        "results/weaves_1143/field --name period_oracle_more"),
        *(BenchmarkReport(f"Generic descriptors of the photo beside its structure descriptor: {kind}",
                          (f"bench/descriptor_candidates_{name}.md",),
                          f"{py}/descriptor_candidates.py "
                          + " ".join(f"--set results/{folder}/run results/{folder}/field" for folder in folders)
                          + f" --name descriptor_candidates_{name}")
          for kind, name, folders in DESCRIPTOR_SETS),
        BenchmarkReport("The photo's spectrum rings as a candidate of the classifier of record, four fresh sets",
                        ("bench/photo_candidates.md",),
                        f"{py}/photo_candidates.py results/microscope_1152/run results/microscope_1153/run "
                        "results/weaves_1154/run results/weaves_1155/run (each set: .venv/bin/snakemake --cores 2 "
                        "field_set --configfile config/config.yaml config/overlays/<set>.yaml && .venv/bin/snakemake "
                        "--cores 2 --config samples=results/<set>/field/samples.tsv results=results/<set>/run -- "
                        "results/<set>/run/features/photo/table.parquet)"),
        BenchmarkReport("The photo's spectrum rings as a candidate of the classifier of record, the design set",
                        ("bench/photo_candidates_design.md",),
                        f"{py}/photo_candidates.py results --name photo_candidates_design"),
        BenchmarkReport("The photo described from a 512 px working image, screening on the real sets A-E",
                        ("bench/photo512_screening.md",),
                        f"{py}/photo_candidates.py "
                        + " ".join(f"results/real/{s}/run results/exp512/{s}" for s in "abcde")
                        + " --name photo512_screening (each results/exp512/<set>: .venv/bin/snakemake --cores 2 "
                        "--configfile config/config.yaml config/overlays/photo_512.yaml --config "
                        "samples=results/real/<set>/samples.tsv results=results/exp512/<set> -- "
                        "results/exp512/<set>/features/photo/table.parquet; thirty-seventh session)"),
        BenchmarkReport("The photo's whole frame as a member of the vote, screening on the real sets A-E and two "
                        "synthetic runs",
                        ("bench/frame_screening.md", "bench/frame_screening_synthetic.md"),
                        f"{py}/frame_candidate.py " + " ".join(f"results/real/{s}/run" for s in "abcde")
                        + f" --with-only --name frame_screening; {py}/frame_candidate.py results "
                        "results/microscope_1208/run --with-only --name frame_screening_synthetic (thirty-eighth "
                        "session; the rule in docs/design.md)"),
        BenchmarkReport("The photo's whole frame as a member of the vote, confirmation on the real sets F and G",
                        ("bench/frame_confirm_f.md", "bench/frame_confirm_g.md"),
                        f"{py}/frame_candidate.py results/real/f/run --with-only --name frame_confirm_f; "
                        f"{py}/frame_candidate.py results/real/g/run --with-only --name frame_confirm_g (thirty-eighth "
                        "session; G made by real_photos.py --sets a b c d e f g --last-short and run with the defaults)"),
        BenchmarkReport("The fitted relief against the photo alone, image by image, over eleven runs",
                        ("bench/fit_vs_photo.md",),
                        f"{py}/fit_vs_photo.py results results/holdout_1207/run results/microscope_1208/run "
                        "results/microscope_1209/run " + " ".join(f"results/real/{s}/run" for s in "abcdefg")
                        + " (thirty-ninth session; every run with the defaults, its reports/prepared.tsv remade by "
                        "--forcerun rejection_report)"),
        BenchmarkReport("Each held-out image scored with its tiles, three fresh sets",
                        ("bench/held_out_tiles.md",),
                        f"{py}/held_out_tiles.py results/microscope_1156/run results/weaves_1157/run "
                        "results/holdout_1158/run (each set rendered and given photo features by the commands in "
                        "config/overlays/<set>.yaml)"),
        BenchmarkReport("Each held-out image scored with its tiles, the design set and the screening sets",
                        ("bench/held_out_tiles_design.md",),
                        f"{py}/held_out_tiles.py results results/microscope_1152/run results/microscope_1153/run "
                        "results/weaves_1154/run results/weaves_1155/run --name held_out_tiles_design"),
        BenchmarkReport("The yarn axes pick the thread period's peak, screening",
                        ("bench/period_axes_native.md",),
                        f"{py}/period_axes.py --native results/microscope_1152/field results/weaves_1154/field "
                        "results/microscope_1153/field results/weaves_1155/field"),
        BenchmarkReport("The yarn axes pick the thread period's peak, confirmation",
                        ("bench/period_axes.md",),
                        f"{py}/period_axes.py --set results/microscope_1156/run results/microscope_1156/run_axes "
                        "results/microscope_1156/field --set results/weaves_1157/run results/weaves_1157/run_axes "
                        "results/weaves_1157/field --set results/holdout_1158/run results/holdout_1158/run_axes "
                        "results/holdout_1158/holdout (RUN prepared with config/overlays/period_weighted.yaml, the "
                        "default until then; AXES_RUN with the default)"),
        BenchmarkReport("A (1, 1) harmonic stepped down where the photo shows no yarn axes, screening",
                        ("bench/period_axes_harmonic_screening.md",),
                        f"{py}/period_axes.py --native results/microscope_1152/field results/microscope_1153/field "
                        "results/microscope_1156/field results/weaves_1154/field results/weaves_1155/field "
                        "results/weaves_1157/field --peaks weighted axes axes_harmonic "
                        "--name period_axes_harmonic_screening"),
        BenchmarkReport("A (1, 1) harmonic stepped down where the photo shows no yarn axes, confirmation",
                        ("bench/period_axes_harmonic.md",),
                        f"{py}/period_axes.py --set results/microscope_1159/run results/microscope_1159/run_axes_harmonic "
                        "results/microscope_1159/field --set results/weaves_1160/run results/weaves_1160/run_axes_harmonic "
                        "results/weaves_1160/field --candidate axes_harmonic --name period_axes_harmonic (RUN prepared "
                        "with config/overlays/period_axes.yaml, the default until then, CANDIDATE_RUN with "
                        "the default since (axes_harmonic); the commands are in config/overlays/period_axes.yaml)"),
        BenchmarkReport("A higher harmonic stepped down where the photo shows no yarn axes, screening",
                        ("bench/period_fundamental_screening.md",),
                        f"{py}/period_axes.py --native results/microscope_1152/field results/microscope_1153/field "
                        "results/microscope_1156/field results/weaves_1154/field results/weaves_1155/field "
                        "results/weaves_1157/field --peaks axes_harmonic axes_fundamental "
                        "--name period_fundamental_screening"),
        BenchmarkReport("A higher harmonic stepped down where the photo shows no yarn axes, confirmation",
                        ("bench/period_fundamental_confirmation.md",),
                        f"{py}/period_axes.py --native results/microscope_1159/field results/weaves_1160/field --peaks "
                        "axes_harmonic axes_fundamental --name period_fundamental_confirmation"),
        BenchmarkReport("A higher harmonic stepped down where the photo shows no yarn axes, confirmation with the proxy",
                        ("bench/period_fundamental.md",),
                        f"{py}/period_axes.py --set results/microscope_1159/run_axes_harmonic "
                        "results/microscope_1159/run_axes_fundamental results/microscope_1159/field --set "
                        "results/weaves_1160/run_axes_harmonic results/weaves_1160/run_axes_fundamental "
                        "results/weaves_1160/field --candidate axes_fundamental --name period_fundamental (the "
                        "commands are in config/overlays/period_axes_harmonic.yaml)"),
        BenchmarkReport("The thread period against the truth in its window, the eight capture sets",
                        ("bench/period_truth_window.md",),
                        f"{py}/period_axes.py --native results/microscope_1152/field results/microscope_1153/field "
                        "results/microscope_1156/field results/weaves_1154/field results/weaves_1155/field "
                        "results/weaves_1157/field results/microscope_1159/field results/weaves_1160/field --peaks "
                        "axes_harmonic axes_fundamental --name period_truth_window (the sections above compare with "
                        "the whole frame's magnification; see design.md)"),
        BenchmarkReport("The thread period against the truth in its window, a fresh three-weave set",
                        ("bench/period_truth_window_1161.md",),
                        f"{py}/period_axes.py --native results/weaves_1161/field --peaks axes_harmonic axes_fundamental "
                        "--name period_truth_window_1161 (seed 20261161, rendered after the yardstick was chosen)"),
        BenchmarkReport("The thread period against the truth in its window, a second fresh three-weave set",
                        ("bench/period_truth_window_1163.md",),
                        f"{py}/period_axes.py --native results/weaves_1163/field --peaks axes_fundamental "
                        "--name period_truth_window_1163 (seed 20261163, seventeenth session)"),
        BenchmarkReport("The thread period on the shading and on the luminance",
                        ("bench/period_fields.md",),
                        f"{py}/period_axes.py --native results/microscope_1208/field results/microscope_1152/field "
                        "results/microscope_1153/field results/weaves_1154/field --peaks axes_fundamental --fields "
                        "shading luminance --sheets results/real/a/samples.tsv results/real/b/samples.tsv "
                        "results/real/c/samples.tsv results/real/d/samples.tsv results/real/e/samples.tsv "
                        "--name period_fields (thirty-seventh session; each field set rendered by the commands in "
                        "config/overlays/<set>.yaml, the real sheets by real_photos.py)"),
        BenchmarkReport("Thread period of fitted normal maps, strongest peak against power times frequency",
                        ("bench/fitted_period.md",),
                        f"{py}/fitted_period.py results:config/samples.tsv results/holdout/run:results/holdout/samples.tsv "
                        "results/weaves/run_strongest:results/weaves/field/samples.tsv "
                        "results/weaves/run:results/weaves/field/samples.tsv "
                        "results/period_confirm/run:results/period_confirm/field/samples.tsv"),
        BenchmarkReport("Classifier of record with and without the photo's own sets among its candidates",
                        ("bench/record_candidates.md",),
                        f"{py}/record_candidates.py results results/holdout/run results/weaves/run "
                        "results/holdout_confirm/run results/weaves_confirm/run"),
        BenchmarkReport("Classifier of record: one column set per fold against the posteriors of the best K averaged",
                        ("bench/record_ensemble.md",),
                        f"{py}/record_candidates.py results results/weaves/run results/confirm_1126/run "
                        "results/weaves_confirm/run results/weaves_fresh/run --ensemble 1 2 3 5 --name record_ensemble"),
        BenchmarkReport("Other classifiers beside QDA", ("bench/classifiers_beside.md",),
                        f"{py}/classifiers_beside.py results results/confirm_1126/run results/weaves/run "
                        "results/weaves_confirm/run results/weaves_fresh/run results/weaves_period/run"),
        BenchmarkReport("Classifier of record: the inner criterion that chooses each fold's set, screening",
                        ("bench/record_criteria_screening.md",),
                        f"{py}/record_candidates.py results results/weaves/run --criterion accuracy logloss tiebreak "
                        "repeated --name record_criteria_screening"),
        BenchmarkReport("Classifier of record: the inner criterion that chooses each fold's set, confirmation",
                        ("bench/record_criteria_confirmation.md",),
                        f"{py}/record_candidates.py results/confirm_1126/run results/weaves_confirm/run "
                        "results/weaves_fresh/run results/weaves_period/run --criterion accuracy tiebreak "
                        "--name record_criteria_confirmation"),
        BenchmarkReport("Classifier of record: a preferred set left only on evidence, screening",
                        ("bench/record_prefer_screening.md",),
                        f"{py}/record_candidates.py results results/weaves_1140/run results/microscope_1142/run "
                        "results/weaves_1143/run results/weaves_1144/run --prefer none photo_texture photo_structure "
                        "--name record_prefer_screening"),
        BenchmarkReport("Classifier of record: a preferred set left only on evidence, first confirmation",
                        ("bench/record_prefer_confirmation.md",),
                        f"{py}/record_candidates.py results/weaves_1144/run --prefer none photo_texture "
                        "--name record_prefer_confirmation"),
        BenchmarkReport("Classifier of record: a preferred set left only on evidence, second confirmation",
                        ("bench/record_prefer_second.md",),
                        f"{py}/record_candidates.py results/weaves_1145/run --prefer none photo_structure "
                        "--name record_prefer_second"),
        BenchmarkReport("Classifier of record: the preferred set on a fresh held-out set",
                        ("bench/record_prefer_holdout_1147.md",),
                        f"{py}/record_candidates.py results/holdout_1147/run --prefer none photo_structure "
                        "--name record_prefer_holdout_1147"),
        BenchmarkReport("Classifier of record: the preferred set on a fresh microscope-like set",
                        ("bench/record_prefer_microscope_1148.md",),
                        f"{py}/record_candidates.py results/microscope_1148/run --prefer none photo_structure "
                        "--name record_prefer_microscope_1148"),
        BenchmarkReport("Classifier of record: the preferred set on a second fresh microscope-like set",
                        ("bench/record_prefer_microscope_1149.md",),
                        f"{py}/record_candidates.py results/microscope_1149/run --prefer none photo_structure "
                        "--name record_prefer_microscope_1149"),
        BenchmarkReport("Classifier of record: the sign test's level, screening on the four sets scored after the rule",
                        ("bench/record_alpha_screening.md",),
                        f"{py}/record_candidates.py results/weaves_1145/run results/holdout_1147/run results/microscope_1148/run "
                        "results/microscope_1149/run --prefer photo_structure --alpha 0.15 0.3 --name record_alpha_screening"),
        BenchmarkReport("Classifier of record: the sign test's level, confirmation on two fresh sets",
                        ("bench/record_alpha_confirmation.md",),
                        f"{py}/record_candidates.py results/microscope_1150/run results/holdout_1151/run "
                        "--prefer none photo_structure --alpha 0.05 0.3 --name record_alpha_confirmation"),
        BenchmarkReport("Classifier of record: the fitted BRDF beside the photo's structure as the preferred set, held-out 1164",
                        ("bench/record_brdf_1164.md",),
                        f"{py}/record_candidates.py results/holdout_1164/run --prefer photo_structure_brdf "
                        "--name record_brdf_1164"),
        BenchmarkReport("Classifier of record voting over its candidates, on the six sets looked at",
                        ("bench/record_vote_looked.md",),
                        f"{py}/record_candidates.py results results/holdout_1162/run results/holdout_1164/run "
                        "results/holdout_1166/run results/weaves_1163/run results/microscope_1165/run --vote "
                        "--name record_vote_looked"),
        BenchmarkReport("Classifier of record voting over its candidates, two fresh sets (the rule's test)",
                        ("bench/record_vote_fresh.md",),
                        f"{py}/record_candidates.py results/holdout_1167/run results/microscope_1168/run --vote "
                        "--name record_vote_fresh"),
        BenchmarkReport("Pruning the record's vote, on microscope-like 1168 (looked at), two levels",
                        ("bench/prune_probe.md",),
                        f"{py}/record_candidates.py results/microscope_1168/run --prune 0.05 0.2 --name prune_probe"),
        BenchmarkReport("Pruning the record's vote, 1168 with each image given another's fitted features (looked at)",
                        ("bench/prune_spoiled_1168.md",),
                        f"{py}/record_candidates.py results/microscope_1168/run --prune 0.05 --fitted-of-others 1 "
                        "--name prune_spoiled_1168"),
        BenchmarkReport("Pruning the record's vote, on the seven sets looked at",
                        ("bench/prune_looked.md",),
                        f"{py}/record_candidates.py results results/holdout_1162/run results/holdout_1164/run "
                        "results/holdout_1166/run results/holdout_1167/run results/weaves_1163/run "
                        "results/microscope_1165/run --prune 0.05 --name prune_looked"),
        BenchmarkReport("Pruning the record's vote, two fresh sets (the rule's part a)",
                        ("bench/prune_fresh.md",),
                        f"{py}/record_candidates.py results/holdout_1169/run results/microscope_1170/run --prune 0.05 "
                        "--name prune_fresh"),
        BenchmarkReport("Pruning the record's vote, two fresh sets with each image given another's fitted features "
                        "(the rule's part b)", ("bench/prune_spoiled_fresh.md",),
                        f"{py}/record_candidates.py results/holdout_1169/run results/microscope_1170/run --prune 0.05 "
                        "--fitted-of-others 1 --name prune_spoiled_fresh"),
        BenchmarkReport("A looser prune (0.2) against 0.05: screening on design and microscope-like 1173",
                        ("bench/prune_loose_screen.md",),
                        f"{py}/record_candidates.py results results/microscope_1173/run --prune 0.05 0.2 "
                        "--name prune_loose_screen"),
        *(BenchmarkReport(f"A looser prune (0.2) against 0.05: fresh {label}{spoiled_label}",
                          (f"bench/prune_loose{spoiled}_{seed}.md",),
                          f"{py}/record_candidates.py results/{folder}/run --prune 0.05 0.2{option} "
                          f"--name prune_loose{spoiled}_{seed}")
          for seed, folder, label in (("1174", "microscope_1174", "microscope-like 1174"),
                                      ("1175", "holdout_1175", "held-out 1175"))
          for spoiled, option, spoiled_label in (("", "", ""), ("_spoiled", " --fitted-of-others 1",
                                                                  ", each image given another's fitted features"))),
        BenchmarkReport("Pruning on real photos: screening on halves A and B, 2026-12-07",
                        ("bench/prune_real_screen.md",),
                        f"{py}/record_candidates.py results/real/a/run results/real/b/run --prune 0.05 0.2 "
                        "--name prune_real_screen"),
        BenchmarkReport("Pruning on real photos: confirmation on the fresh set C, 2026-12-07",
                        ("bench/prune_real_c.md",),
                        f"{py}/record_candidates.py results/real/c/run --prune 0.05 --name prune_real_c"),
        BenchmarkReport("Pruning on real photos: confirmation on the fresh set C, each image given another's fitted "
                        "features, 2026-12-07", ("bench/prune_real_c_spoiled.md",),
                        f"{py}/record_candidates.py results/real/c/run --prune 0.05 --fitted-of-others 1 "
                        "--name prune_real_c_spoiled"),
        BenchmarkReport("Pruning on real photos: confirmation on the embedded design run, 2026-12-07",
                        ("bench/prune_design_1207.md",),
                        f"{py}/record_candidates.py results --prune 0.05 --name prune_design_1207"),
        *(BenchmarkReport(f"The photo's spectrum rings in the vote: {label}, 2026-12-07", (f"bench/spectrum_vote_{name}.md",),
                          f"{py}/record_candidates.py {run} --add-photo spectrum --name spectrum_vote_{name}")
          for name, run, label in (("a", "results/real/a/run", "screening on the real set A"),
                                   ("b", "results/real/b/run", "screening on the real set B"),
                                   ("c", "results/real/c/run", "screening on the real set C"),
                                   ("d", "results/real/d/run", "confirmation on the fresh real set D"),
                                   ("1207", "results/holdout_1207/run", "confirmation on held-out 1207"))),
        BenchmarkReport("What the fit cannot explain, as a fitted column: screening on the design set",
                        ("bench/fit_residual_screen.md",), f"{py}/fit_residual.py results --name fit_residual_screen"),
        BenchmarkReport("What the fit cannot explain, as a fitted column: fresh held-out 1176 and microscope-like 1177",
                        ("bench/fit_residual_fresh.md",),
                        f"{py}/fit_residual.py results/holdout_1176/run results/microscope_1177/run "
                        "--name fit_residual_fresh"),
        BenchmarkReport("What the fit cannot explain, as a fitted column: the fresh sets, each image given another's "
                        "fitted features", ("bench/fit_residual_spoiled_fresh.md",),
                        f"{py}/fit_residual.py results/holdout_1176/run results/microscope_1177/run "
                        "--fitted-of-others 1 --name fit_residual_spoiled_fresh"),
        BenchmarkReport("What the fit cannot explain, as a fitted column: held-out 1176 refitted with the share recorded",
                        ("bench/fit_residual_native_1176.md",),
                        f"{py}/fit_residual.py results/holdout_1176/run --name fit_residual_native_1176 (after "
                        "`--forcerun fit_normals` on the run)"),
        BenchmarkReport("Tiles as extra training rows: every feature set on whole images and with tiles",
                        ("bench/tiles_gain.md",),
                        f"{py}/tiles_gain.py results results/confirm_1126/run results/weaves_confirm/run"),
        BenchmarkReport("The weave rings on the sets that chose and confirmed them", ("bench/weave_rings.md",),
                        f"{py}/weave_rings.py results/microscope/run results/weaves/run results/weaves_confirm/run "
                        "results/microscope_confirm/run results/weaves_fresh/run results/weaves_period/run "
                        "results/confirm_1126/run results --no-record"),
        BenchmarkReport("The weave rings on three fresh sets", ("bench/weave_rings_fresh.md",),
                        f"{py}/weave_rings.py results/microscope_1130/run results/weaves_1131/run results/holdout_1132/run "
                        "--name weave_rings_fresh"),
        BenchmarkReport("The weave rings in the fitted relief's sets, three fresh sets", ("bench/weave_rings_fitted.md",),
                        f"{py}/weave_rings.py results/microscope_1133/run results/weaves_1134/run results/holdout_1135/run "
                        "--name weave_rings_fitted"),
        BenchmarkReport("The thread period from prepare, confirmation", ("bench/period_source.md",),
                        f"{py}/setting_gain.py --rerun config/overlays/period_prepare.yaml --drop features/photo --drop features/fitted "
                        "results/weaves_1140/run:results/weaves_1140_p/run:results/weaves_1140/field/samples.tsv "
                        "results/microscope_1142/run:results/microscope_1142_p/run:results/microscope_1142/field/samples.tsv "
                        "results:results/embedded_p/run --name period_source (results/microscope_1142 "
                        "on a GPU machine)"),
        BenchmarkReport("The thread period where the photo is larger than the working image, confirmation",
                        ("bench/period_auto.md",),
                        f"{py}/{PERIOD_AUTO_RERUN} "
                        "results/weaves_1143/run:results/weaves_1143_auto/run:results/weaves_1143/field/samples.tsv "
                        "--name period_auto"),
        BenchmarkReport("The thread period where the photo is larger than the working image, under the current record",
                        ("bench/period_auto_fresh.md",),
                        f"{py}/{PERIOD_AUTO_RERUN} "
                        + " ".join(period_auto_pair("results", folder, images) for _, folder, images in PERIOD_AUTO_SETS)
                        + " --name period_auto_fresh"),
        BenchmarkReport("Turned and zoomed views as extra training rows, screening", ("bench/views_gain.md",),
                        f"{py}/views_gain.py results results/weaves/run results/microscope/run"),
        BenchmarkReport("Tiles on the three-weave set of seed 20261203", ("bench/tiles_gain_weaves.md",),
                        f"{py}/tiles_gain.py results/weaves/run --name tiles_gain_weaves"),
        BenchmarkReport("Tiles on the fresh three-weave set (seed 20261226)", ("bench/tiles_gain_weaves_fresh.md",),
                        f"{py}/tiles_gain.py results/weaves_fresh/run --name tiles_gain_weaves_fresh"),
        BenchmarkReport("Feature sets on the design set, the held-out set and both pooled", ("bench/pooled_sets.md",),
                        f"{py}/pooled_sets.py"),
        BenchmarkReport("Feature sets on the two three-weave sets and both pooled", ("bench/pooled_weaves.md",),
                        f"{py}/pooled_sets.py --design results/weaves/run --holdout results/weaves_confirm/run --name pooled_weaves"),
        BenchmarkReport("Feature sets on the two fresh three-weave sets (seeds 20261226 and 20261227) and both pooled",
                        ("bench/pooled_weaves_fresh.md",),
                        f"{py}/pooled_sets.py --design results/weaves_fresh/run --holdout results/weaves_period/run "
                        "--name pooled_weaves_fresh"),
        BenchmarkReport("Feature sets by capture, the four three-weave sets pooled", ("bench/pooled_captures.md",),
                        f"{py}/pooled_captures.py"),
        BenchmarkReport("SLURM profile against the local executor", ("bench/slurm.md",), f"{py}/slurm_run.py"),
        BenchmarkReport("Spectral peaks found in maps without threads", ("bench/noise_peaks.md",), f"{py}/noise_peaks.py"),
        BenchmarkReport("The paper's class subsets: the classifier of record, the fitted maps alone, the photo alone",
                        ("bench/class_subsets.md",),
                        f"{py}/class_subsets.py --holdout results/holdout_1162/run results/holdout_1164/run "
                        "results/holdout_1166/run (classifier of record: `auto`, the default of its day)"),
        BenchmarkReport("The paper's class subsets: the voting classifier of record",
                        ("bench/class_subsets_record_vote.md",),
                        f"{py}/class_subsets.py --holdout results/holdout_1162/run results/holdout_1164/run "
                        "results/holdout_1166/run results/holdout_1167/run --record-only --name class_subsets_record_vote "
                        "(every set voting, the default of its day)"),
        BenchmarkReport("The paper's class subsets: the classifier of record, its vote pruned, LBP at the thread period",
                        ("bench/class_subsets_record_canonical.md",),
                        f"{py}/class_subsets.py --holdout results/holdout_1171/run --record-only "
                        "--name class_subsets_record_canonical"),
        BenchmarkReport("The paper's class subsets: the classifier of record with the fit's unexplained share",
                        ("bench/class_subsets_record_unexplained.md",),
                        f"{py}/class_subsets.py --design results --record-only --name class_subsets_record_unexplained"),
        BenchmarkReport("The paper's class subsets: the classifier of record, a fresh clone's default run, 2026-12-02",
                        ("bench/class_subsets_record_1202.md",),
                        f"{py}/class_subsets.py --design results --holdout --record-only --name class_subsets_record_1202"),
        BenchmarkReport("The paper's class subsets: the classifier of record, a fresh clone's default run and held-out 1178, "
                        "2026-12-03", ("bench/class_subsets_record_1203.md",),
                        f"{py}/class_subsets.py --design results --holdout results/holdout_1178/run --record-only "
                        "--name class_subsets_record_1203"),
        BenchmarkReport("The paper's class subsets: the classifier of record, a fresh clone's default run and held-out 1178, "
                        "2026-12-04 (both rerun on this day's machine)", ("bench/class_subsets_record_1204.md",),
                        f"{py}/class_subsets.py --design results --holdout results/holdout_1178/run --record-only "
                        "--name class_subsets_record_1204"),
        BenchmarkReport("The paper's class subsets: the classifier of record, the default run and held-out 1207, 2026-12-07",
                        ("bench/class_subsets_record_1207.md",),
                        f"{py}/class_subsets.py --design results --holdout results/holdout_1207/run --record-only "
                        "--name class_subsets_record_1207"),
        BenchmarkReport("The mixed dye layout (`fit.normals.layout_mixing: mixed`), screening on the three weaves of 1163, "
                        "2026-12-04", ("bench/layout_mixed_1163.md",),
                        f"{py}/setting_gain.py --rerun config/config.yaml --drop 'fit/*/normals' "
                        "results/weaves_1163/run:results/weaves_1163/run_mixed:results/weaves_1163/field/samples.tsv "
                        f"--name layout_mixed_1163 {MIXED_LAYOUT_NOTE}"),
        BenchmarkReport("The mixed dye layout, confirmation on the fresh three weaves of 1205, 2026-12-04",
                        ("bench/layout_mixed_1205.md",),
                        f"{py}/setting_gain.py --rerun config/config.yaml --drop 'fit/*/normals' "
                        "results/weaves_1205/run:results/weaves_1205/run_mixed:results/weaves_1205/field/samples.tsv "
                        f"--name layout_mixed_1205 {MIXED_LAYOUT_NOTE} (after the commands of `config/overlays/weaves_1205.yaml`)"),
        BenchmarkReport("The mixed dye layout, confirmation on the embedded design run and held-out 1178, 2026-12-04",
                        ("bench/layout_mixed_clean.md",),
                        f"{py}/setting_gain.py --rerun config/config.yaml --drop 'fit/*/normals' "
                        "results/design:results/design_mixed results/holdout_1178/run:results/holdout_1178/run_mixed:"
                        f"results/holdout_1178/holdout/samples.tsv --name layout_mixed_clean {MIXED_LAYOUT_NOTE} (`results/design` "
                        "held a copy of the default run's prepared, fit, features and reports folders)"),
        BenchmarkReport("The paper's class subsets: the classifier of record with the mixed dye layout, the default run and "
                        "held-out 1178, 2026-12-04", ("bench/class_subsets_record_1204_mixed.md",),
                        f"{py}/class_subsets.py --design results --holdout results/holdout_1178/run_mixed --record-only "
                        "--name class_subsets_record_1204_mixed"),
        BenchmarkReport("Does the relief repeat where the photo repeats? The default run, the three weaves of 1163, and "
                        "1163 with the repeat prior, 2026-12-05", ("bench/repeat_correlation.md",),
                        f"{py}/repeat_correlation.py results:config/samples.tsv "
                        "results/weaves_1163/run_mixed:results/weaves_1163/field/samples.tsv "
                        "results/weaves_1163/run_repeat:results/weaves_1163/field/samples.tsv --name repeat_correlation"),
        BenchmarkReport("The repeat prior (`fit.normals.repeat_weight` 0.03), screening on the three weaves of 1163, "
                        "2026-12-05 (rejected)", ("bench/repeat_prior_1163.md",),
                        f"{py}/setting_gain.py --rerun config/overlays/repeat_prior.yaml --drop 'fit/*/normals' "
                        "results/weaves_1163/run_mixed:results/weaves_1163/run_repeat:results/weaves_1163/field/samples.tsv "
                        "--name repeat_prior_1163"),
        BenchmarkReport("Invariance of predictions, refitted, LBP at the field's pixels (the default until the "
                        "twenty-third session)", ("bench/invariance_pixels/invariance_fitted.md",),
                        f"{py}/invariance_fitted.py --images all --prefer photo_structure_brdf --scores-only "
                        "(the feature tables of the run without `--scores-only`, 2026-11-29; `record` is the pruned vote; "
                        "moved from results/bench/invariance)"),
        BenchmarkReport("Invariance of predictions, refitted", ("bench/invariance/invariance_fitted.md",),
                        f"{py}/invariance_fitted.py --images all --features-only --prefer photo_structure_brdf (the refits of the "
                        "run above reused; run with `--overlay config/overlays/canonical_lbp.yaml`, whose `lbp_scale: "
                        "canonical` is the default since and which was then removed)"),
        BenchmarkReport("Invariance of predictions, refitted, with the fit's unexplained share, 2026-12-02",
                        ("bench/invariance_1202/invariance_fitted.md",),
                        f"{py}/invariance_fitted.py --images all --prefer photo_structure_brdf --out results/bench/invariance_1202 "
                        "(every transformed photo prepared and fitted from scratch, after a fresh clone's default run)"),
        BenchmarkReport("Invariance of predictions, refitted, 2026-12-04",
                        ("bench/invariance_1204/invariance_fitted.md",),
                        f"{py}/invariance_fitted.py --images all --out results/bench/invariance_1204 "
                        "(every transformed photo prepared and fitted from scratch, after a fresh clone's default run)"),
        BenchmarkReport("Invariance of predictions, refitted with the mixed dye layout, 2026-12-04",
                        ("bench/invariance_1204_mixed/invariance_fitted.md",),
                        f"{py}/invariance_fitted.py --images all --out results/bench/invariance_1204_mixed "
                        "(every transformed photo prepared and fitted from scratch, after the default run; other runs "
                        "shared the two cores)"),
        BenchmarkReport("Invariance of predictions, refitted, with the photo's spectrum rings in the vote, 2026-12-07",
                        ("bench/invariance_1207/invariance_fitted.md",),
                        f"{py}/invariance_fitted.py --images all --out results/bench/invariance_1207 "
                        "(every transformed photo prepared and fitted from scratch; other jobs shared the two cores for "
                        "its first third)"),
        BenchmarkReport("The invariance benchmark's own noise: every photo refitted as it is, with other render samples",
                        ("bench/invariance_noise_1203/invariance_fitted.md",),
                        f"{py}/invariance_fitted.py --images all --transforms refit --overlay config/overlays/fit_seed_1.yaml "
                        "--out results/bench/invariance_noise_1203 (after a fresh clone's default run)"),
        BenchmarkReport("LBP at the canonical period under the pruned vote: five sets (the rule's parts b and c)",
                        ("bench/canonical_lbp_record.md",),
                        f"{py}/setting_gain.py results:results/canonical/design results/holdout_1169/run:"
                        "results/canonical/holdout_1169 results/microscope_1170/run:results/canonical/microscope_1170 "
                        "results/holdout_1171/run:results/canonical/holdout_1171 results/microscope_1172/run:"
                        "results/canonical/microscope_1172 --name canonical_lbp_record (each `results/canonical/<set>` "
                        "holds the reports of a copy of the run whose features and classifier were rerun with "
                        "the overlay `features: {structure: {lbp_scale: canonical}}`, the fits reused; made before it became the default)"),
        BenchmarkReport("prepare on large photos: time and peak memory", ("bench/large_photo.md",),
                        f"{py}/large_photo.py --formats jpg,png16,exr"),
        BenchmarkReport("What accuracy costs: presets and knobs", ("reports/cost_accuracy.md",), f"{py}/cost_accuracy.py"),
        BenchmarkReport("Fidelity presets on a CUDA GPU and on the CPU", ("bench/gpu/gpu_presets.md",),
                        f"{py}/gpu_presets.py --preset default --jobs 16 && {py}/gpu_presets.py --preset paper --alone 1 --jobs 0"
                        f" (on the GPU machine), then here {py}/gpu_presets.py --preset default --variant llvm_ad_rgb --jobs 0"
                        f" && {py}/gpu_presets.py --preset fast --variant llvm_ad_rgb --jobs 0"),
        BenchmarkReport("The paper preset beside the default on a CUDA GPU, 2026-11-28", ("bench/gpu9/gpu_presets.md",),
                        f"{py}/gpu_presets.py --preset paper --images {SUBSET} --alone 0 --jobs 7 --budget-s 360 --out results/bench/gpu9 "
                        f"&& {py}/gpu_presets.py --preset default --alone 0 --jobs 16 --budget-s 104 --out results/bench/gpu9 "
                        "(on the GPU machine; the first stopped at its budget before writing its rows), then here "
                        f"{py}/gpu_presets.py --preset paper --images {SUBSET} --jobs 7 --collect 358.3 --device 'NVIDIA H200' "
                        f"--out results/bench/gpu9 (358.3 s: Snakemake's logged time) && {py}/gpu_presets.py --report --out results/bench/gpu9"),
        BenchmarkReport("Classification from the GPU-fitted maps", ("bench/gpu_scores.md",),
                        f"{py}/tiles_gain.py results/bench/gpu/default --name gpu_scores"),
        BenchmarkReport("Normal-map stage knobs", ("reports/normals_sweep.md",), f"{py}/normals_sweep.py"),
        BenchmarkReport("Render noise per sampler", ("bench/sampler_noise.md",), f"{py}/sampler_noise.py"),
        BenchmarkReport("Planned effects against the full-effects baseline",
                        ("bench/effects_all/effects_ablation.md", "bench/effects/effects_ablation.md"),
                        f"{py}/effects_ablation.py --images all --out results/bench/effects_all"),
        BenchmarkReport("Fit time per image, kernel cache cold and warm", ("bench/fit_timing/fit_timing.md",),
                        f"{py}/fit_timing.py"),
        BenchmarkReport("Fit time per image, settings side by side", ("bench/fit_speed/fit_speed.md",),
                        f"{py}/fit_speed.py --variants default,lean,fast"),
        BenchmarkReport("Fit time per image, default and fast with one pending scheduler wake-up, 2026-11-28",
                        ("bench/fit_speed_sched/fit_speed.md",),
                        f"{py}/fit_speed.py --variants default,fast --out results/bench/fit_speed_sched"),
        BenchmarkReport("Fit time per image, reused intersections against the default", ("bench/fit_speed_cycle/fit_speed.md",),
                        f"{py}/fit_speed.py --variants default,seed_cycle --out results/bench/fit_speed_cycle"),
        BenchmarkReport("Reused intersections: the figures a change to the fit must keep", ("bench/seed_cycle_figures/run_figures.md",),
                        f"{py}/run_figures.py results results/exp_cycle/design results/holdout_1151/run "
                        "results/exp_cycle/holdout_1151 --out results/bench/seed_cycle_figures"),
        BenchmarkReport("Fit time per image on field photos, prepare included", ("bench/fit_speed_field/fit_speed.md",),
                        f"{py}/fit_speed.py --sheet results/weaves/field/samples.tsv --prepare --variants default --rounds 1 "
                        f"--images {FIELD_TIMED} --out results/bench/fit_speed_field"),
        BenchmarkReport("Fit time per image on an idle machine, 2026-11-28 evening", ("bench/fit_speed_quiet/fit_speed.md",),
                        f"{py}/fit_speed.py --variants default,fast --out results/bench/fit_speed_quiet"),
        BenchmarkReport("The normal-map step on the same evening: the machine's speed", ("bench/backward_pass_1128.md",),
                        f"{py}/backward_pass.py --ways direct --name backward_pass_1128 (run alone, right after "
                        "fit_speed_quiet)"),
        BenchmarkReport("Fit time per image, 2026-11-29 morning", ("bench/fit_speed_1129/fit_speed.md",),
                        f"{py}/fit_speed.py --variants default,fast --out results/bench/fit_speed_1129 (run alone, right "
                        "after the design run)"),
        BenchmarkReport("Fit time per image, 2026-12-01 evening", ("bench/fit_speed_1201/fit_speed.md",),
                        f"{py}/fit_speed.py --variants default,fast --out results/bench/fit_speed_1201 (run alone, right "
                        "after the design run)"),
        BenchmarkReport("Fit time per image, 2026-12-03 morning", ("bench/fit_speed_1203/fit_speed.md",),
                        f"{py}/fit_speed.py --variants default,fast --out results/bench/fit_speed_1203 (run alone, right "
                        "after a fresh clone's default run)"),
        BenchmarkReport("The normal-map step on the same morning, 2026-12-03: the machine's speed",
                        ("bench/backward_pass_1203.md",),
                        f"{py}/backward_pass.py --ways direct --name backward_pass_1203 (run alone, right after "
                        "fit_speed_1203)"),
        BenchmarkReport("Fit time per image on field photos, prepare included, 2026-11-29 morning",
                        ("bench/fit_speed_field_1129/fit_speed.md",),
                        f"{py}/fit_speed.py --sheet results/weaves_1163/field/samples.tsv --prepare --variants default "
                        f"--rounds 1 --images {FIELD_TIMED} --out results/bench/fit_speed_field_1129 (run alone)"),
        BenchmarkReport("The normal-map step on the same morning: the machine's speed", ("bench/backward_pass_s17.md",),
                        f"{py}/backward_pass.py --ways direct --name backward_pass_s17 (run alone, right after "
                        "fit_speed_1129)"),
        BenchmarkReport("Fit time per image on field photos, prepare included, 2026-12-03",
                        ("bench/fit_speed_field_1203/fit_speed.md",),
                        f"{py}/fit_speed.py --sheet results/weaves_1163/field/samples.tsv --prepare --variants default "
                        f"--rounds 1 --images {FIELD_TIMED} --out results/bench/fit_speed_field_1203 (run alone)"),
        BenchmarkReport("The normal-map step right after it, 2026-12-03: the machine's speed",
                        ("bench/backward_pass_1203b.md",),
                        f"{py}/backward_pass.py --ways direct --name backward_pass_1203b (run alone, right after "
                        "fit_speed_field_1203)"),
        BenchmarkReport("Fit time per image against the code issue 18 was filed with (d2ab236), 2026-12-04",
                        ("bench/fit_speed_1204/fit_speed.md",),
                        f"{py}/fit_speed.py --variants default,fast,at:d2ab236 --out results/bench/fit_speed_1204 (run alone, "
                        "after a fresh clone's default run)"),
        BenchmarkReport("A lighter fast preset against fast and the code of d2ab236, 2026-12-04",
                        ("bench/fit_speed_fast_lite/fit_speed.md",),
                        f"{py}/fit_speed.py --variants fast,fast_lite,at:d2ab236 --rounds 1 --out results/bench/fit_speed_fast_lite "
                        "(run alone, right after fit_speed_1204)"),
        BenchmarkReport("Fit time per image after the fixed-cost cuts, against d2ab236 and the code before them, 2026-12-07",
                        ("bench/fit_speed_1207/fit_speed.md",),
                        f"{py}/fit_speed.py --variants fast,default,at:d2ab236,at:7dad036 --rounds 2 "
                        "--out results/bench/fit_speed_1207 (run alone)"),
        BenchmarkReport("The lighter fast preset's second timing, after the fixed-cost cuts, 2026-12-07",
                        ("bench/fit_speed_fast_lite_1207/fit_speed.md",),
                        f"{py}/fit_speed.py --variants fast,fast_lite,at:d2ab236 --rounds 1 "
                        "--out results/bench/fit_speed_fast_lite_1207 (run alone)"),
        BenchmarkReport("The lighter fast preset against fast on the 42 embedded images, 2026-12-07",
                        ("bench/run_figures_fast_lite/run_figures.md",),
                        f"{py}/run_figures.py results/exp_fast results/exp_fast_lite --out results/bench/run_figures_fast_lite "
                        "(after .venv/bin/snakemake --cores 2 --config preset=fast results=results/exp_fast and "
                        ".venv/bin/snakemake --cores 2 --configfile config/config.yaml config/overlays/fast_lite.yaml "
                        "--config results=results/exp_fast_lite)"),
        BenchmarkReport("Fit time per image on field photos against the code of d2ab236, prepare included, 2026-12-04",
                        ("bench/fit_speed_field_1204/fit_speed.md",),
                        f"{py}/fit_speed.py --sheet results/weaves_1163/field/samples.tsv --variants default,at:d2ab236 "
                        f"--rounds 2 --images {FIELD_TIMED} --out results/bench/fit_speed_field_1204 (run alone)"),
        BenchmarkReport("Run-to-run noise and the lean fit", ("bench/run_figures/run_figures.md",),
                        f"{py}/run_figures.py results results/exp_seed/design results/exp_lean/design results/holdout/run "
                        "results/exp_lean/holdout results/holdout_confirm/run results/exp_seed/confirm results/exp_lean/confirm "
                        "results/weaves_confirm/run results/exp_seed/weaves results/exp_lean/weaves"),
        BenchmarkReport("Snakemake's scheduler: one pending wake-up against a wake-up chain per job event",
                        ("bench/scheduler_wakeups/scheduler_wakeups.md",), f"{py}/scheduler_wakeups.py"),
        BenchmarkReport("Where a fit job's seconds go", ("bench/job_costs.md",), f"{py}/job_costs.py"),
        BenchmarkReport("Whole sheet on a CUDA GPU with more jobs side by side", ("bench/gpu_jobs/gpu_presets.md",),
                        f"{py}/gpu_presets.py --preset default --alone 0 --jobs J --budget-s 130 --out results/bench/gpu_jobs/jJ "
                        "for J in 16, 24 and 32, one after the other on one GPU machine after a one-image warm-up run "
                        f"(--alone 1 --jobs 0), then here {py}/gpu_presets.py --report --out results/bench/gpu_jobs"),
        BenchmarkReport("The normal-map step: backward pass and freezing", ("bench/backward_pass.md",),
                        f"{py}/backward_pass.py"),
        BenchmarkReport("The normal-map stage's forward render, part by part", ("bench/render_split.md",),
                        f"{py}/render_split.py"),
        BenchmarkReport("The normal-map step on a CUDA GPU: backward pass and freezing", ("bench/backward_pass_cuda.md",),
                        f"{py}/backward_pass.py --variant cuda_ad_rgb --name backward_pass_cuda"),
        BenchmarkReport("The normal-map step on a CUDA GPU, normal map without the hardware texture",
                        ("bench/backward_pass_cuda_noaccel.md",),
                        f"{py}/backward_pass.py --variant cuda_ad_rgb --ways direct 'direct, frozen' --no-texture-accel "
                        "--name backward_pass_cuda_noaccel"),
        BenchmarkReport("A rerun from scratch against the run", ("bench/rerun_identity.md",), f"{py}/rerun_identity.py"),
        BenchmarkReport("Scaling with cores and resolution", ("bench/scaling/scaling.md",), f"{py}/scaling.py"),
        BenchmarkReport("Scaling with cores and resolution, 2026-12-03", ("bench/scaling_1203/scaling.md",),
                        f"{py}/scaling.py --out results/bench/scaling_1203 (run alone)"),
        BenchmarkReport("The `paper` preset's projected time", ("reports/paper_projection.md",), f"{py}/paper_projection.py"),
        BenchmarkReport("Lower bounds on the fold normal error", ("reports/fold_bounds.md",), f"{py}/fold_bounds.py"),
    ]


def workflow_reports(results: Path) -> list[tuple[str, list[Path], str]]:
    """Reports of the design run embedded as they are: title, where to look, the command that makes them."""
    reports = results / "reports"
    return [
        ("The paper's experiments, fitted normal maps", [reports / "fitted" / "paper_tables.md"],
         ".venv/bin/snakemake --cores 2 paper_reports"),
        ("The paper's experiments, ground-truth normal maps", [reports / "truth" / "paper_tables.md"],
         ".venv/bin/snakemake --cores 2 paper_reports --config features='{normal_source: truth}'"),
        ("Fitted against true relief", [reports / "diagnosis" / "spectra.md"],
         ".venv/bin/snakemake --cores 2 spectra_diagnosis"),
    ]


def page_sections(results: Path, earlier: dict[str, str] | None = None) -> list[str]:
    """The page's header and its sections, each starting with its ``## `` title.

    ``earlier`` (title -> section of the page being replaced) lets the sections that compare runs keep the rows and
    columns of runs whose files are not on this machine.
    """
    kept = earlier or {}
    runs = workflow_runs(results)
    header = ("# Measured results\n\n"
              f"Written by `{THIS_COMMAND}` from the files under `{shown(results)}/`; do not edit by hand. Each section "
              "names its files and the date they were written: figures from different dates may come from different "
              "versions of the code. A section whose file is missing says how to make it (or, written with `--keep-earlier`, "
              "keeps the text of the page it replaced, whose source line dates it). The images are synthetic "
              "(`data/synthetic/`, README \"The embedded synthetic dataset\"), far easier than real photos: the "
              "figures check the pipeline, not the method.")
    sections = [header, runs_section(runs, kept.get("Runs", "")),
                classifier_section(runs, kept.get("Classifier of record (LOOCV)", "")),
                feature_sets_section(runs, kept.get("Feature sets side by side", "")),
                fit_accuracy_section(runs, kept.get("Inverse renderer against the ground truth", "")),
                rule_times_section(runs, kept.get("Time and memory per rule", ""))]
    sections += [embedded_section(title, paths, command) for title, paths, command in workflow_reports(results)]
    sections += [embedded_section(report.title, [results / path for path in report.candidates], report.command)
                 for report in benchmark_reports(results)]
    return sections


def section_title(section: str) -> str:
    """The title of a ``## `` section (its first line without the marker)."""
    return section.splitlines()[0][3:]


def earlier_sections(page: str) -> dict[str, str]:
    """Title -> section text of a page this script wrote (its ``## `` sections)."""
    return headed_parts(page, "##")


def keep_earlier(sections: list[str], earlier: dict[str, str]) -> list[str]:
    """``sections`` with each whole-section ``not measured`` replaced by the earlier page's measured text of that title."""
    def unmeasured(section: str) -> bool:
        return section.partition("\n\n")[2].startswith("not measured")

    kept = []
    for section in sections:
        previous = earlier.get(section_title(section), "")
        kept.append(previous if unmeasured(section) and previous and not unmeasured(previous) else section)
    return kept


def only_titles(sections: list[str], earlier: dict[str, str], titles: list[str]) -> list[str]:
    """``sections`` with every one not named in ``titles`` (and present on the earlier page) as the earlier page has it."""
    unknown = set(titles) - {section_title(section) for section in sections[1:]}
    if unknown:
        raise SystemExit(f"no section titled {', '.join(sorted(unknown))}")
    return [sections[0]] + [section if section_title(section) in titles else earlier.get(section_title(section), section)
                            for section in sections[1:]]


def results_page(sections: list[str]) -> str:
    """The whole of ``docs/results.md`` from its header and sections, with a table of contents."""
    contents = "\n".join(f"- {section_title(section)}" for section in sections[1:])
    return "\n\n".join([sections[0], "Contents:\n\n" + contents, *sections[1:]]) + "\n"


def main() -> None:
    """Parse the options, build the page and write it atomically."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", default=schema_defaults()["results"],
                        help="results folder of the design run (default: the config schema's results)")
    parser.add_argument("--out", default="docs/results.md", help="page to write (default: docs/results.md)")
    parser.add_argument("--keep-earlier", action="store_true",
                        help="where a section's file is missing here, keep that section as the page being replaced has it "
                             "(its source line still names the file and the date it was written)")
    parser.add_argument("--only", nargs="+", metavar="TITLE", default=[],
                        help="rewrite only the sections of these titles and keep every other as the page has it "
                             "(for a machine that holds only some of the runs)")
    args = parser.parse_args()
    results, out = ROOT / args.results, ROOT / args.out
    earlier = earlier_sections(out.read_text(encoding="utf-8")) if out.exists() else {}
    sections = page_sections(results, earlier if args.keep_earlier or args.only else None)
    if args.keep_earlier:
        sections = keep_earlier(sections, earlier)
    if args.only:
        sections = only_titles(sections, earlier, args.only)
    write_text(out, results_page(sections))
    print(f"wrote {shown(out)}")


if __name__ == "__main__":
    main()
