"""The paper's three classification experiments and the spectrum-settings sweep.

Both recompute the Fourier features of every usable image from its normal
map (an FFT per map and setting, no refitting) and score QDA by leave-one-out
cross-validation (:func:`clothscope.classify.loocv.loocv`). Roughness and specular
come from the same normal source as the maps.

Paper experiments (Chambers et al., section 4):

=====================  ======================================  ==  =====  ==  ====  =====
experiment             classes                                 n   alpha  DC  peak  paper
=====================  ======================================  ==  =====  ==  ====  =====
5 classes              broadcloth, canvas, satin, chiffon,     2   2      20  15    60 %
                       cotton_gauze
7 classes              + knit_jersey, velvet                   2   3      20  25    38 %
6 classes (no velvet)  + knit_jersey                           4   3      20  15    58.3 %
=====================  ======================================  ==  =====  ==  ====  =====

Each is reported twice: with the paper-faithful peak definitions
(``SpectrumSettings.paper()``: ``R_m`` = largest radius, ``n_peaks`` = all
peaks) and with this project's default (``radius_normalisation`` /
``peak_count`` / ``strong_fraction`` from the config). The window and
reference resolution come from the config too.
"""
from __future__ import annotations

import itertools
import os
import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd

from clothscope.classify.loocv import loocv
from clothscope.core.atomic import write_text
from clothscope.core.figures import new_figure, save_png
from clothscope.features.paper import SpectrumResult, SpectrumSettings, analyse_normal_map, count_peaks, peak_features
from clothscope.features.sources import STATUS_OK, NormalInput, load_normal_input
from clothscope.features.table import paper_feature_columns, read_table, spectrum_settings, specular_norm


@dataclass(frozen=True)
class Experiment:
    """One of the paper's classification experiments."""

    name: str
    classes: tuple[str, ...]
    n_peaks: int
    alpha: float
    dc_radius: float
    peak_size: float
    paper_accuracy: float
    paper_label: str


FIVE = ("broadcloth", "canvas", "satin", "chiffon", "cotton_gauze")
PAPER_EXPERIMENTS = (
    Experiment("5 classes", FIVE, 2, 2.0, 20.0, 15.0, 0.60, "60%"),
    Experiment("7 classes", FIVE + ("knit_jersey", "velvet"), 2, 3.0, 20.0, 25.0, 0.38, "38%"),
    Experiment("6 classes (no velvet)", FIVE + ("knit_jersey",), 4, 3.0, 20.0, 15.0, 0.583, "58.3%"),
)
#: The two peak definitions reported for every experiment.
OPTIONS = ("paper", "default")
OPTION_LABELS = {
    "paper": "paper-faithful (R_m = largest radius, n_peaks = all peaks)",
    "default": "clothscope default",
}


@dataclass
class LabelledMap:
    """A usable, labelled image: its class, normal map and BSDF parameters."""

    image_id: str
    fabric_class: str
    normals: np.ndarray
    roughness: float
    specular: float


def usable_maps(table: pd.DataFrame, loaded: dict[str, NormalInput]) -> list[LabelledMap]:
    """Labelled rows with status ok whose normal map loaded, in table order."""
    maps = []
    for _, row in table.iterrows():
        label = str(row["fabric_class"] or "").strip()
        item = loaded.get(str(row["image_id"]))
        if row["status"] != STATUS_OK or not label or item is None or item.status != STATUS_OK:
            continue
        maps.append(LabelledMap(str(row["image_id"]), label, item.normals, item.roughness, item.specular))
    return maps


def _frame(maps: list[LabelledMap], features: list[dict[str, float]]) -> pd.DataFrame:
    rows = []
    for item, values in zip(maps, features):
        rows.append({"image_id": item.image_id, "fabric_class": item.fabric_class, "roughness": item.roughness,
                     "specular_norm": specular_norm(item.specular), **values})
    return pd.DataFrame(rows)


def _score(frame: pd.DataFrame, n_peaks: int, reg: float | str) -> dict[str, Any]:
    result = loocv(frame, paper_feature_columns(n_peaks), reg)
    return {"correct": result.correct, "n": result.n, "accuracy": result.accuracy, "wilson_low": result.wilson_low,
            "wilson_high": result.wilson_high, "chance": result.chance_uniform, "n_classes": len(result.classes),
            "notes": "; ".join(result.notes)}


def experiment_settings(experiment: Experiment, base: SpectrumSettings, option: str) -> SpectrumSettings:
    """The experiment's n / alpha / DC / peak size on top of ``base``, paper-faithful or default."""
    settings = replace(base, n_peaks=experiment.n_peaks, alpha=experiment.alpha, dc_radius=experiment.dc_radius,
                       peak_size=experiment.peak_size)
    return settings.paper() if option == "paper" else settings


def paper_table(maps: list[LabelledMap], base: SpectrumSettings, reg: float | str = "auto") -> pd.DataFrame:
    """LOOCV of every paper experiment under both peak definitions.

    Returns
    -------
    pandas.DataFrame
        One row per experiment and option: ``experiment``, ``option``,
        ``classes``, settings, ``correct``, ``n``, ``accuracy``, Wilson 95 %
        bounds, ``chance`` (1 / classes), ``paper_accuracy``, ``status``
        (``ok`` or why it was not run) and ``notes``.
    """
    rows = []
    for experiment, option in itertools.product(PAPER_EXPERIMENTS, OPTIONS):
        settings = experiment_settings(experiment, base, option)
        subset = [m for m in maps if m.fabric_class in experiment.classes]
        present = sorted({m.fabric_class for m in subset})
        absent = [c for c in experiment.classes if c not in present]
        row: dict[str, Any] = {
            "experiment": experiment.name, "option": option, "option_label": OPTION_LABELS[option],
            "classes": ", ".join(experiment.classes), "n_peaks": experiment.n_peaks, "alpha": experiment.alpha,
            "dc_radius": experiment.dc_radius, "peak_size": experiment.peak_size,
            "radius_normalisation": settings.radius_normalisation, "peak_count": settings.peak_count,
            "paper_accuracy": experiment.paper_accuracy, "paper_label": experiment.paper_label,
            "correct": 0, "n": 0, "accuracy": 0.0, "wilson_low": 0.0, "wilson_high": 0.0,
            "chance": 1.0 / len(experiment.classes), "n_classes": len(present), "status": STATUS_OK,
            "notes": f"classes absent: {', '.join(absent)}" if absent else "",
        }
        try:
            frame = _frame(subset, [analyse_normal_map(m.normals, settings).features for m in subset])
            scored = _score(frame, experiment.n_peaks, reg)
            notes = "; ".join(x for x in (row["notes"], scored.pop("notes")) if x)
            row.update(scored, notes=notes)
        except (ValueError, KeyError) as err:
            row["status"] = f"not run: {str(err).splitlines()[0]}"
        rows.append(row)
    return pd.DataFrame(rows)


def _pct(value: float) -> str:
    return f"{100 * value:.1f}%"


def paper_markdown(table: pd.DataFrame, source: str) -> str:
    """The paper table as Markdown, the paper's figures quoted beside ours."""
    lines = [
        f"# Paper experiments, {source} normal maps",
        "",
        "LOOCV accuracy of QDA on roughness, specular_norm, r_1..r_n, z_1..z_n, n_peaks; features recomputed from each "
        "image's normal map with the experiment's settings (DC radius and peak size at the configured reference "
        "resolution). 95% Wilson score interval; chance = 1 / number of classes. Paper figures from Chambers et al., "
        "section 4 (real photos; ours are the workflow's images).",
        "",
        "| experiment | spectrum option | n | alpha | DC | peak | images | correct | LOOCV accuracy | 95% Wilson | chance | paper |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for _, r in table.iterrows():
        if r["status"] == STATUS_OK:
            acc, wilson = _pct(r["accuracy"]), f"{_pct(r['wilson_low'])}-{_pct(r['wilson_high'])}"
        else:
            acc, wilson = r["status"], "-"
        lines.append(
            f"| {r['experiment']} | {r['option_label']} | {r['n_peaks']} | {r['alpha']:g} | {r['dc_radius']:g} | "
            f"{r['peak_size']:g} | {r['n']} | {r['correct']} | {acc} | {wilson} | {_pct(r['chance'])} | {r['paper_label']} |"
        )
    lines += ["", "Classes: " + "; ".join(f"{e.name}: {', '.join(e.classes)}" for e in PAPER_EXPERIMENTS)]
    notes = [f"- {r['experiment']} / {r['option']}: {r['notes']}" for _, r in table.iterrows() if r["notes"]]
    if notes:
        lines += ["", "Notes:", *notes]
    return "\n".join(lines) + "\n"


def _check_finite(frame: pd.DataFrame, name: str) -> None:
    numeric = frame.select_dtypes(include="number")
    if numeric.size and not np.isfinite(numeric.to_numpy(dtype=float)).all():
        raise ValueError(f"refusing to write {name}: it holds non-finite numbers")


def write_paper_tables(table: pd.DataFrame, source: str, md_path: str | os.PathLike[str], csv_path: str | os.PathLike[str]) -> None:
    """Write the paper table as Markdown and CSV, atomically."""
    _check_finite(table, str(csv_path))
    write_text(csv_path, table.to_csv(index=False, lineterminator="\n"))
    write_text(md_path, paper_markdown(table, source))


# --------------------------------------------------------------------------- sweep


def truncated_features(result: SpectrumResult, n: int) -> dict[str, float]:
    """The features :func:`analyse_normal_map` gives with ``n_peaks = n``, from a result of any ``n_peaks``.

    ``n_peaks`` only truncates the ordered candidate list, so one analysis
    serves every ``n``.
    """
    s = result.settings
    return peak_features(list(result.candidates[:n]), n, count_peaks(list(result.candidates), s.peak_count, s.strong_fraction))


def sweep(maps: list[LabelledMap], base: SpectrumSettings, grid: dict[str, list[Any]], classes: list[str],
          reg: float | str = "auto") -> pd.DataFrame:
    """LOOCV accuracy over a grid of ``n_peaks`` x ``alpha`` x ``dc_radius`` x ``peak_size``.

    Each map is analysed once per (DC radius, peak size, alpha) with the
    largest ``n_peaks`` of the grid; smaller ``n`` are truncations
    (:func:`truncated_features`). Images of other classes are left out.
    """
    subset = [m for m in maps if m.fabric_class in set(classes)]
    n_values = sorted({int(n) for n in grid["n_peaks"]})
    rows = []
    for dc, peak, alpha in itertools.product(grid["dc_radius"], grid["peak_size"], grid["alpha"]):
        settings = replace(base, n_peaks=max(n_values), alpha=float(alpha), dc_radius=float(dc), peak_size=float(peak))
        results = [analyse_normal_map(m.normals, settings) for m in subset]
        for n in n_values:
            row: dict[str, Any] = {"n_peaks": n, "alpha": float(alpha), "dc_radius": float(dc), "peak_size": float(peak)}
            try:
                row.update(_score(_frame(subset, [truncated_features(r, n) for r in results]), n, reg), status=STATUS_OK)
            except ValueError as err:
                row.update(correct=0, n=len(subset), accuracy=0.0, wilson_low=0.0, wilson_high=0.0, chance=0.0,
                           n_classes=0, notes="", status=f"not run: {str(err).splitlines()[0]}")
            rows.append(row)
    return pd.DataFrame(rows)


def sweep_figure(table: pd.DataFrame, target: str | os.PathLike[str], title: str) -> None:
    """Heatmaps of LOOCV accuracy: one panel per (DC radius, peak size), n_peaks across, alpha down."""
    dcs, peaks = sorted(table["dc_radius"].unique()), sorted(table["peak_size"].unique())
    ns, alphas = sorted(table["n_peaks"].unique()), sorted(table["alpha"].unique())
    fig = new_figure(3.2 * len(peaks) + 1.5, 3.3 * len(dcs) + 1.0, layout="constrained")
    axes = np.atleast_2d(fig.subplots(len(dcs), len(peaks), squeeze=False))
    image = None
    for i, dc in enumerate(dcs):
        for j, peak in enumerate(peaks):
            ax = axes[i, j]
            cell = table[(table["dc_radius"] == dc) & (table["peak_size"] == peak)]
            grid = np.zeros((len(alphas), len(ns)))
            for _, r in cell.iterrows():
                grid[alphas.index(r["alpha"]), ns.index(r["n_peaks"])] = r["accuracy"]
            image = ax.imshow(grid, vmin=0.0, vmax=1.0, cmap="viridis", origin="lower", aspect="auto")
            for a in range(len(alphas)):
                for k in range(len(ns)):
                    ax.text(k, a, f"{100 * grid[a, k]:.0f}", ha="center", va="center", fontsize=7,
                            color="white" if grid[a, k] < 0.6 else "black")
            ax.set_xticks(range(len(ns)), [str(int(n)) for n in ns])
            ax.set_yticks(range(len(alphas)), [f"{a:g}" for a in alphas])
            ax.set_xlabel("n (peaks kept)")
            ax.set_ylabel("alpha (floor std devs)")
            ax.set_title(f"DC radius {dc:g}, peak size {peak:g}", fontsize=9)
    if image is not None:
        fig.colorbar(image, ax=axes.ravel().tolist(), label="LOOCV accuracy")
    fig.suptitle(title)
    save_png(fig, target, dpi=100)


def write_sweep(table: pd.DataFrame, csv_path: str | os.PathLike[str], png_path: str | os.PathLike[str], title: str) -> None:
    """Write the sweep table (CSV) and heatmap (PNG), atomically."""
    _check_finite(table, str(csv_path))
    write_text(csv_path, table.to_csv(index=False, lineterminator="\n"))
    sweep_figure(table, png_path, title)


def timed(function, *args, **kwargs) -> tuple[Any, float]:
    """``function(*args, **kwargs)`` and its wall time in seconds."""
    started = time.perf_counter()
    value = function(*args, **kwargs)
    return value, time.perf_counter() - started



# --------------------------------------------------------------------------- rule entry points


def load_maps(table_path: str | os.PathLike[str], source: str, images: dict[str, dict[str, str]]) -> list[LabelledMap]:
    """Normal maps of the feature table's usable labelled rows, reloaded from their normal source.

    ``images`` maps an image id to its sheet ``path``, ``fit_dir`` (the fit_normals folder) and ``prepared_dir``
    (the prepared folder: the photo source's maps, and the frame the true maps are put in).
    """

    table = read_table(table_path)
    wanted = table[(table["status"] == STATUS_OK) & (table["fabric_class"].astype(str).str.strip() != "")]
    loaded = {}
    for image_id in wanted["image_id"].astype(str):
        entry = images[image_id]
        # Algorithm 2 reads the normals (the photo's luminance) only, so the descriptors' fields do not matter here
        folder = entry.get("fit_dir") if source == "fitted" else entry.get("prepared_dir")
        loaded[image_id] = load_normal_input(source, entry["path"], folder, "relief", "luminance")
    return usable_maps(table, loaded)


def paper_tables_job(table_path: str, source: str, images: dict[str, dict[str, str]], features_config: dict[str, Any],
                     reg: float | str, md_path: str, csv_path: str, log: Any = None) -> pd.DataFrame:
    """The ``paper_tables`` rule."""

    maps = load_maps(table_path, source, images)
    table, seconds = timed(paper_table, maps, spectrum_settings(features_config), reg)
    write_paper_tables(table, source, md_path, csv_path)
    if log is not None:
        for _, r in table.iterrows():
            log.info("%s / %s: %s/%s (%s) in %.1f s", r["experiment"], r["option"], r["correct"], r["n"], r["status"], seconds)
    return table


def sweep_job(table_path: str, source: str, images: dict[str, dict[str, str]], features_config: dict[str, Any],
              sweep_config: dict[str, Any], reg: float | str, csv_path: str, png_path: str, log: Any = None) -> pd.DataFrame:
    """The ``sweep`` rule."""

    maps = load_maps(table_path, source, images)
    grid = {k: list(sweep_config[k]) for k in ("n_peaks", "alpha", "dc_radius", "peak_size")}
    table, seconds = timed(sweep, maps, spectrum_settings(features_config), grid, list(sweep_config["classes"]), reg)
    best = table.sort_values(["accuracy", "n_peaks"], ascending=[False, True]).iloc[0]
    title = (f"LOOCV accuracy, {len(sweep_config['classes'])} classes, {source} normal maps "
             f"(best {100 * best['accuracy']:.0f}%: n={best['n_peaks']}, alpha={best['alpha']:g}, "
             f"DC={best['dc_radius']:g}, peak={best['peak_size']:g})")
    write_sweep(table, csv_path, png_path, title)
    if log is not None:
        log.info("sweep of %d settings over %d images in %.1f s", len(table), len(maps), seconds)
    return table
