"""Benchmark: what accuracy costs in time, per fidelity preset and per knob.

Each variant is a preset plus optional knob overrides, run through the real
workflow into its own results folder (``<out>/<variant>/``), prepared images
copied from the main results when present. Presets run on the whole sample
sheet and are scored by LOOCV too; knob variants run on a subset (one image
per class by default) and are scored on reconstruction only. The default
preset's numbers are read from the main results folder when it is complete
(``results/reports/fit_accuracy.csv``), so they are not recomputed. Every other
variant's folder is emptied first, so its fits and times come from the code as
it is now (``--reuse`` keeps them, to redraw the report only).

    .venv/bin/python workflow/benchmarks/cost_accuracy.py [--variants fast,iters40,...] [--out results/bench/cost] [--reuse]

Writes ``results/reports/cost_accuracy.csv`` (one row per image and variant,
with the variant's LOOCV accuracy when measured),
``results/reports/cost_accuracy.png`` (median time against median error per
variant, Pareto front drawn) and ``results/reports/cost_accuracy.md`` (the
summary, the effects ablation side by side, and what was not measured and why).
The ``cuda`` variant runs only where a CUDA GPU is present; ``paper`` is opt-in.
"""
from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from harness import ROOT, SUBSET, publish, seed_prepared, snakemake, write_sheet

from clothscope.core.atomic import write_text, write_with
from clothscope.core.runtime import cuda_available
from clothscope.evaluate.accuracy import effects_comparison

#: variant -> (preset, overlay of knobs, runs on the whole sheet)
VARIANTS: dict[str, tuple[str, dict, bool]] = {
    "fast": ("fast", {}, True),
    "default": ("default", {}, True),
    "normals-iters-20": ("default", {"fit": {"normals": {"iterations": 20, "joint_iterations": 15}}}, False),
    "normals-iters-40": ("default", {"fit": {"normals": {"iterations": 40, "joint_iterations": 30}}}, False),
    "spp-1": ("default", {"fit": {"geometry": {"spp": 4}, "material": {"spp": 1}, "normals": {"spp": 1, "spp_grad": 1}}}, False),
    "spp-16": ("default", {"fit": {"geometry": {"spp": 64}, "material": {"spp": 16}, "normals": {"spp": 16, "spp_grad": 16}}}, False),
    # the normal-map stage at 4 spp in both passes (the sample counts before the loss image took more than the gradient)
    "normals-spp-4": ("default", {"fit": {"normals": {"spp": 4, "spp_grad": 4}}}, False),
    # the default before the stages stratified their pixel samples (independent samples, 16 in the normal-map loss image)
    "independent-samples": ("default", yaml.safe_load((ROOT / "config" / "overlays" / "independent_samples.yaml").read_text()),
                            True),
    # the normal-map stage's height map in Large Steps coordinates with Uniform Adam (docs/design.md)
    "large-steps": ("default", yaml.safe_load((ROOT / "config" / "overlays" / "large_steps.yaml").read_text()), True),
    "geometry-iters-50": ("default", {"fit": {"geometry": {"iterations": 50}}}, False),
    "geometry-spp-16": ("default", {"fit": {"geometry": {"spp": 16}}}, False),  # the geometry default before 2026-11-24
    "geometry-res-128": ("default", {"fit": {"geometry": {"resolution": 128}}}, False),
    # effects ablation in the same report: the default preset with every stage forced to full effects
    "full-effects": ("default", {"fit": {"full_effects": True}}, False),
    # the default preset on the CUDA variant; only where a CUDA GPU is present (otherwise reported as not measured)
    "cuda": ("default", {"variant": "cuda_ad_rgb"}, True),
    # opt-in (not in the default list): the whole sheet with LOOCV, about an hour per image on 2 CPU cores
    "paper": ("paper", {}, True),
}
DEFAULT_VARIANTS = [name for name in VARIANTS if name != "paper"]
PAPER_PROJECTION = ROOT / "results" / "reports" / "paper_projection.csv"
GPU_REPORT = ROOT / "results" / "bench" / "gpu" / "gpu_presets.md"
ERRORS = ("psnr_db", "fold_normal_error_deg", "roughness_error", "period_error")


def run_variant(name: str, out: Path, subset: list[str], reuse: bool = False) -> pd.DataFrame:
    """Fit (and for whole-sheet variants classify) one variant; returns its fit_accuracy rows.

    Without ``reuse`` the variant's folder is emptied first: the workflow runs with
    mtime rerun triggers, so results of older code would otherwise be taken as current.
    """
    preset, overlay, whole = VARIANTS[name]
    main = ROOT / "results"
    if name == "default" and (main / "reports" / "fit_accuracy.csv").exists() and (main / "reports" / "fitted" / "accuracy.json").exists():
        results = main
    else:
        results = out / name
        if not reuse:
            shutil.rmtree(results, ignore_errors=True)
        results.mkdir(parents=True, exist_ok=True)
        seed_prepared(results)
        (results / "overlay.yaml").write_text(json.dumps(overlay))
        sheet = write_sheet(None if whole else subset, results / "samples.tsv")
        targets = [str(results / "reports" / "fit_accuracy.csv")]
        if whole:
            targets.append(str(results / "reports" / "fitted" / "accuracy.json"))
        snakemake(["--rerun-triggers", "mtime", "--configfile", "config/config.yaml", str(results / "overlay.yaml"), "--quiet",
                   "all", "--config", f"preset={preset}", f"samples={sheet}", f"results={results}", "--", *targets])
    table = pd.read_csv(results / "reports" / "fit_accuracy.csv").assign(variant=name, preset=preset, whole_sheet=whole)
    accuracy = results / "reports" / "fitted" / "accuracy.json"
    table["loocv_accuracy"] = json.loads(accuracy.read_text())["accuracy"] if whole and accuracy.exists() else np.nan
    return table


def pareto(points: pd.DataFrame, cost: str, error: str) -> pd.DataFrame:
    """Variants no other variant beats on both cost and error (lower is better on both)."""
    ordered = points.sort_values([cost, error])
    front, best = [], np.inf
    for _, row in ordered.iterrows():
        if row[error] < best:
            front.append(row)
            best = row[error]
    return pd.DataFrame(front)


def plot(summary: pd.DataFrame, target: Path) -> None:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    panels = [("psnr_loss_db", "40 dB - median re-render PSNR (dB)"), ("fold_normal_error_deg", "median fold normal error (deg)"),
              ("period_error", "median thread-period error (fraction)"), ("loocv_error", "LOOCV error, 7 classes (fraction)")]
    fig = Figure(figsize=(12, 9), layout="constrained")
    FigureCanvasAgg(fig)
    for ax, (column, label) in zip(fig.subplots(2, 2).ravel(), panels):
        data = summary.dropna(subset=[column])
        for whole, (marker, color) in ((True, ("o", "tab:blue")), (False, ("^", "tab:orange"))):
            group = data[data["whole_sheet"] == whole]
            if group.empty:
                continue
            images = int(group["images"].max())
            ax.scatter(group["total_s"], group[column], marker=marker, color=color,
                       label=f"{'presets' if whole else 'knob variants'} ({images} images)")
            for _, row in group.iterrows():
                ax.annotate(row["variant"], (row["total_s"], row[column]), fontsize=8, xytext=(4, 3), textcoords="offset points")
            front = pareto(group, "total_s", column)
            if len(front) > 1:
                ax.plot(front["total_s"], front[column], color=color, alpha=0.7, label=f"Pareto front ({images} images)")
        ax.legend(loc="upper right", fontsize=8)
        ax.set_xlabel("median fit wall time per 256 px image (s, 2 cores shared by 2 jobs)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    fig.suptitle("clothscope: accuracy against time per fidelity preset and knob (synthetic set; lower is better)")
    write_with(target, lambda tmp: fig.savefig(tmp, format="png", dpi=100))


def report(table: pd.DataFrame, summary: pd.DataFrame, not_measured: dict[str, str]) -> str:
    """Markdown report: the per-variant summary, the effects ablation side by side, and what was not measured."""
    lines = ["# What accuracy costs in time", "",
             "Medians per variant (times per 256 px image with 2 images sharing 2 cores; presets on the whole sheet, "
             "knob variants on the subset; `-`: not measured for that variant).", "",
             summary.round(4).astype(object).where(summary.notna(), "-").to_markdown(index=False), ""]
    if {"default (subset)", "full-effects"} <= set(table["variant"]):
        lines += ["## Effects ablation: planned effects against forced full effects (same images)", "",
                  effects_comparison(table, "variant", "default (subset)", "full-effects")]
    if not_measured:
        lines += ["## Not measured", ""] + [f"- `{name}`: {why}" for name, why in not_measured.items()] + [""]
    return "\n".join(lines)


def paper_not_run() -> str:
    """Why ``paper`` is not in the table, with its projected time where paper_projection.py has measured it."""
    projected = ""
    if PAPER_PROJECTION.exists():
        minutes = float(pd.read_csv(PAPER_PROJECTION)["projected_s"].sum()) / 60.0
        projected = f", projected at about {minutes:.0f} min per image on 2 CPU cores"
    return f"not run: opt-in (`--variants paper`){projected} (workflow/benchmarks/paper_projection.py){gpu_note()}"


def gpu_note() -> str:
    """Where the GPU figures of the presets are, when ``gpu_presets.py`` has written them."""
    return f"; measured on a CUDA GPU in `{GPU_REPORT.relative_to(ROOT)}` (gpu_presets.py)" if GPU_REPORT.is_file() else ""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", default=",".join(DEFAULT_VARIANTS), help=f"any of {', '.join(VARIANTS)}")
    parser.add_argument("--images", default=SUBSET, help="subset for the knob variants")
    parser.add_argument("--out", default="results/bench/cost")
    parser.add_argument("--reuse", action="store_true", help="keep earlier variant results (redraw the report only)")
    args = parser.parse_args()
    out = (ROOT / args.out).resolve()
    subset = args.images.split(",")
    requested = args.variants.split(",")
    unknown = sorted(set(requested) - set(VARIANTS))
    if unknown:
        raise SystemExit(f"cost_accuracy: error: unknown variant(s) {', '.join(unknown)}; choose from {', '.join(VARIANTS)}")
    not_measured = {"paper": paper_not_run()} if "paper" not in requested else {}
    not_measured |= {name: f"not run in this report (`--variants {name}`)" for name in DEFAULT_VARIANTS
                     if name not in requested and name != "cuda"}
    if "cuda" in requested and not cuda_available():
        requested.remove("cuda")
        not_measured["cuda"] = f"not measured here: no CUDA GPU on this machine (Dr.Jit's CUDA backend did not initialise){gpu_note()}"
    table = pd.concat([run_variant(v, out, subset, args.reuse) for v in requested], ignore_index=True)
    default_rows = table[(table["variant"] == "default") & table["image_id"].isin(subset)]
    table = pd.concat([table, default_rows.assign(variant="default (subset)", whole_sheet=False, loocv_accuracy=np.nan)],
                      ignore_index=True)
    reports = ROOT / "results" / "reports"
    reports.mkdir(parents=True, exist_ok=True)
    fitted = table[table["status"] == "fitted"]
    summary = fitted.groupby("variant").agg(
        total_s=("total_s", "median"), max_rss_mb=("max_rss_mb", "max"), psnr_db=("psnr_db", "median"),
        fold_normal_error_deg=("fold_normal_error_deg", "median"), roughness_error=("roughness_error", "median"),
        period_error=("period_error", lambda s: s[s >= 0].median()), loocv_accuracy=("loocv_accuracy", "first"),
        images=("image_id", "count"), whole_sheet=("whole_sheet", "first")).reset_index()
    summary["psnr_loss_db"] = 40.0 - summary["psnr_db"]
    summary["loocv_error"] = 1.0 - summary["loocv_accuracy"]
    write_text(reports / "cost_accuracy_summary.csv", summary.to_csv(index=False))
    plot(summary, reports / "cost_accuracy.png")
    text = report(table, summary, not_measured)
    publish(reports, "cost_accuracy", table, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
