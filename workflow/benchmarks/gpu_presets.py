"""Benchmark: a fidelity preset on a CUDA GPU (or the CPU): seconds per image, where they go, reconstruction, features.

    .venv/bin/python workflow/benchmarks/gpu_presets.py --preset NAME [--variant cuda_ad_rgb] [--images all] [--alone 3] [--jobs 16] [--budget-s 600] [--out results/bench/gpu]

Runs the real workflow with ``--variant`` (CUDA unless told otherwise) into ``<out>/<preset>/``
(``<out>/<preset>-<variant>/`` for another variant): first ``--alone`` images fitted one job at a
time into a ``-alone`` folder beside it (the time one image takes with the device to itself), then
the whole sample sheet with ``--jobs`` jobs side by side (the time the sheet takes; its images
share the device). A run still going after ``--budget-s`` seconds is
stopped (Snakemake removes what it was writing); the images whose three fit stages finished
are then reported, and the others counted as not finished. Targets: ``reports/fit_accuracy.csv``
and the feature tables of the fitted maps and of the photo, so that the classification can be
scored afterwards on any machine, with the same code as every other run::

    .venv/bin/python workflow/benchmarks/tiles_gain.py <out>/default --name gpu_scores

The default preset's fits are also set against a CPU run of the same images (``--cpu-run``,
its ``reports/fit_accuracy.csv``).

Rows of ``<out>/gpu_presets.csv`` (one per image, preset and mode) are replaced per preset, so
presets can be run one call at a time; ``<out>/gpu_presets.md`` summarises all of them. To compare
job counts, run each into a folder of its own under one ``--out`` (``<out>/j16``, ``<out>/j24``) and
write their common report with ``--report --out <out>``. ``--collect WALL_S`` writes the whole-sheet rows of a run
whose script was stopped before it wrote them (the run's folder kept), with the wall seconds Snakemake logged.
With ``--variant cuda_ad_rgb`` (the default) it needs a CUDA GPU that Dr.Jit can start, and
exits with an error otherwise; ``--variant llvm_ad_rgb`` runs the same on the CPU.
"""
from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
from harness import ROOT, STAGES, fit_costs, fresh_run, publish, shown, write_sheet

from clothscope.core.runtime import cuda_available


@dataclass(frozen=True)
class Run:
    """A fidelity preset on a Mitsuba variant."""

    preset: str
    variant: str

    @property
    def name(self) -> str:
        """The run's folder name: the preset, with the variant when it is not CUDA."""
        return self.preset if self.variant == "cuda_ad_rgb" else f"{self.preset}-{self.variant}"


def run_workflow(results: Path, run: Run, sheet: Path, jobs: int, budget_s: float, targets: list[str]) -> tuple[float, bool]:
    """Snakemake ``targets`` with the run's preset and variant; (wall seconds, finished within ``budget_s``)."""
    command = [sys.executable, "-m", "snakemake", "--cores", str(jobs), "--scheduler", "greedy", "--rerun-triggers", "mtime",
               "--quiet", "--config", f"preset={run.preset}", f"variant={run.variant}", f"samples={sheet}", f"results={results}",
               "--", *targets]
    started = time.perf_counter()
    process = subprocess.Popen(command, cwd=ROOT, start_new_session=True)
    try:
        finished = process.wait(timeout=max(budget_s, 1.0)) == 0
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGTERM)  # Snakemake removes the outputs of the jobs it was running
        try:
            process.wait(timeout=60)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
        finished = False
    return time.perf_counter() - started, finished


def finished_images(results: Path, images: list[str]) -> list[str]:
    """Images whose normal-map stage (the last one) wrote its output and its benchmark file."""
    return [i for i in images if (results / "fit" / i / "normals" / "state.json").is_file()
            and (results / "benchmarks" / "fit_normals" / f"{i}.tsv").is_file()]


def targets(results: Path, features: bool) -> list[str]:
    """The fit-accuracy report and, with ``features``, the fitted and photo feature tables (whole images and tiles)."""
    paths = [results / "reports" / "fit_accuracy.csv"]
    if features:
        paths += [results / "features" / s / name for s in ("fitted", "photo") for name in ("table.parquet", "tiles/table.parquet")]
    return [str(p) for p in paths]


def run_mode(results: Path, run: Run, images: list[str], jobs: int, budget_s: float, features: bool) -> pd.DataFrame:
    """Fit ``images`` (``jobs`` side by side) within the budget into the emptied ``results``; one row per image."""
    sheet = fresh_run(results, images)
    wall, complete = run_workflow(results, run, sheet, jobs, budget_s, targets(results, features))
    done = finished_images(results, images)
    if not complete and done:  # the reports of the images that finished (no fitting left to do)
        sheet = write_sheet(done, results / "samples_finished.tsv")
        run_workflow(results, run, sheet, jobs, 600.0, targets(results, False))
    return mode_rows(results, run, images, jobs, wall, complete)


def mode_rows(results: Path, run: Run, images: list[str], jobs: int, wall: float, complete: bool) -> pd.DataFrame:
    """One row per image of a finished or stopped run in ``results``: stage costs, and fit accuracy where it finished."""
    done = finished_images(results, images)
    report = results / "reports" / "fit_accuracy.csv"
    accuracy = pd.read_csv(report) if report.is_file() else pd.DataFrame({"image_id": []})
    accuracy = accuracy[accuracy["image_id"].isin(done)].drop(columns=[c for c in accuracy if c.endswith("_s") or "rss" in c])
    table = pd.DataFrame([{"image_id": image, **fit_costs(results, image)} for image in images]).merge(accuracy, "left", "image_id")
    device = gpu_name() if run.variant.startswith("cuda") else "CPU"
    return table.assign(preset=run.preset, variant=run.variant, device=device, jobs=jobs, images_asked=len(images), images_finished=len(done),
                        run_wall_s=round(wall, 1), run_complete=complete, results=shown(results))


def loop_seconds(results: Path, image: str) -> float:
    """Seconds the three stages' optimisation loops of ``image`` took by their own clock (``loss.csv``), NaN if unfinished."""
    curves = [results / "fit" / image / stage / "loss.csv" for stage in STAGES]
    if not all(curve.is_file() for curve in curves):
        return float("nan")
    return float(sum(pd.read_csv(curve)["seconds"].max() for curve in curves))


def summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per preset and mode: images finished, wall seconds of the run and per image, stage medians, reconstruction."""
    table = table.assign(loops_s=[loop_seconds(ROOT / folder, image) for folder, image in zip(table["results"], table["image_id"])])
    rows = []
    for (preset, variant, mode, _), group in table.groupby(["preset", "variant", "mode", "jobs"], sort=False):
        first = group.iloc[0]
        finished = int(first["images_finished"])
        row = {"preset": preset, "variant": variant, "device": first["device"], "mode": mode, "jobs side by side": int(first["jobs"]),
               "images finished": f"{finished}/{int(first['images_asked'])}", "run wall s": first["run_wall_s"],
               "run wall s per image": round(first["run_wall_s"] / finished, 2) if finished else float("nan"),
               "median fit s per image": group["fit_s"].median()}
        row |= {f"median {stage} s": group[f"{stage}_s"].median() for stage in STAGES}
        row["median loops s"] = group["loops_s"].median()
        row["stages finished (images)"] = " / ".join(str(int(group[f"{stage}_s"].notna().sum())) for stage in STAGES)
        for column, label in (("psnr_db", "median PSNR dB"), ("fold_normal_error_deg", "median fold normal error deg"),
                              ("roughness_error", "median roughness error")):
            row[label] = group[column].median() if column in group else float("nan")
        row["max RSS MB"] = group["max_rss_mb"].max()
        rows.append(row)
    return pd.DataFrame(rows)


def fewest_jobs(rows: pd.DataFrame) -> pd.DataFrame:
    """The rows of the run with the fewest jobs side by side (one sheet run where several job counts were run)."""
    return rows[rows["jobs"] == rows["jobs"].min()]


def against_cpu(table: pd.DataFrame, cpu_report: Path) -> str:
    """The default preset's whole-sheet fit on the GPU against a CPU run's ``fit_accuracy.csv`` of the same images."""
    gpu = fewest_jobs(table[(table["preset"] == "default") & (table["mode"] == "sheet") & (table["variant"] == "cuda_ad_rgb")])
    if not cpu_report.is_file() or gpu.empty or "psnr_db" not in gpu:
        return ""
    both = pd.read_csv(cpu_report).merge(gpu, on="image_id", suffixes=("_cpu", "_gpu"))
    both = both[(both["status_cpu"] == "fitted") & (both["status_gpu"] == "fitted")]
    rows = [{"figure": name, "CPU median": both[f"{name}_cpu"].median(), "GPU median": both[f"{name}_gpu"].median(),
             "largest difference": (both[f"{name}_cpu"] - both[f"{name}_gpu"]).abs().max(),
             "median difference": (both[f"{name}_cpu"] - both[f"{name}_gpu"]).abs().median()}
            for name in ("psnr_db", "fold_normal_error_deg", "roughness_error", "period_error")]
    return "\n".join([f"The default preset's fits on the GPU against `{shown(cpu_report)}` (same images, same seeds; "
                      f"{len(both)} images fitted on both; differences are per image, absolute):", "",
                      pd.DataFrame(rows).round(5).to_markdown(index=False), ""])


def paper_beside_default(table: pd.DataFrame) -> str:
    """Each image the ``paper`` preset fitted on the GPU, with the default preset's fit of the same image there (whole sheet)."""
    figures = ["fit_s", "psnr_db", "fold_normal_error_deg", "roughness_error", "period_error"]
    if "status" not in table or not set(figures) <= set(table):  # no image of any run finished its fit
        return ""
    fitted = table[table["status"] == "fitted"]
    fitted = fitted[fitted["variant"] == "cuda_ad_rgb"]
    paper = fitted[fitted["preset"] == "paper"]
    default = fewest_jobs(fitted[(fitted["preset"] == "default") & (fitted["mode"] == "sheet")])
    both = paper[["image_id", "mode", *figures]].merge(default[["image_id", *figures]], on="image_id", suffixes=(" paper", " default"))
    if both.empty:
        return ""
    return "\n".join(["Images the `paper` preset fitted, beside the default preset's fit of the same image "
                      "(fit seconds: `paper` in its mode, default in its whole-sheet run):", "",
                      both.round(4).to_markdown(index=False), ""])


def dashed(table: pd.DataFrame) -> pd.DataFrame:
    """``table`` with ``-`` where a figure is missing (a stage or a fit that did not finish)."""
    return table.astype(object).where(table.notna(), "-")


def markdown(table: pd.DataFrame, cpu_report: Path) -> str:
    """The summary table with how it was measured, and the default preset against a CPU run."""
    lines = ["# Fidelity presets per device: one image alone and the whole sheet side by side", "",
             "Compare seconds only between rows of the same device.", "",
             "`alone`: one image at a time, the device to itself (seconds per image = one image's latency). "
             "`sheet`: the whole sample sheet with several jobs side by side sharing the device "
             "(run wall seconds per image = throughput). Fit seconds are the three stages' `benchmark:` "
             "files summed, each a separate process (Python start, imports, scene build and kernel compilation included); "
             "loops: the three optimisation loops alone, by the clock of their `loss.csv`.", "",
             dashed(summary(table).round(3)).to_markdown(index=False), "",
             against_cpu(table, cpu_report), paper_beside_default(table),
             "LOOCV: `workflow/benchmarks/tiles_gain.py <out>/default --name gpu_scores` on the feature tables.", ""]
    return "\n".join(lines)


def gpu_name() -> str:
    """The GPU's name as ``nvidia-smi`` reports it, or ``CUDA GPU``."""
    try:
        name = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"], capture_output=True, text=True,
                              check=True).stdout.strip().splitlines()
        return name[0] if name else "CUDA GPU"
    except (OSError, subprocess.CalledProcessError):
        return "CUDA GPU"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", help="fidelity preset (config/presets/<name>.yaml); required unless --report")
    parser.add_argument("--variant", default="cuda_ad_rgb", help="Mitsuba variant (llvm_ad_rgb: the CPU baseline)")
    parser.add_argument("--images", default="all", help="comma-separated image ids of config/samples.tsv, or all")
    parser.add_argument("--alone", type=int, default=3, help="images fitted one at a time first (0: none)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 2, help="jobs side by side for the whole sheet (0: no sheet run)")
    parser.add_argument("--budget-s", type=float, default=3600.0, help="stop the whole-sheet run after this many seconds")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench" / "gpu")
    parser.add_argument("--cpu-run", type=Path, default=ROOT / "results", help="a default-preset CPU run to compare with")
    parser.add_argument("--report", action="store_true",
                        help="only rewrite <out>/gpu_presets.md from <out>/gpu_presets.csv (or, where there is none, "
                             "from the gpu_presets.csv of its folders together: runs with other --jobs)")
    parser.add_argument("--collect", type=float, metavar="WALL_S",
                        help="write the whole-sheet rows of a run stopped before its own report (its folder under --out kept; "
                             "WALL_S: its wall seconds, from Snakemake's log) instead of running it")
    parser.add_argument("--device", help="with --collect: the GPU's name (nvidia-smi's, on the machine that ran it)")
    args = parser.parse_args()
    out = args.out.resolve()
    if args.report:
        tables = [out / "gpu_presets.csv"] if (out / "gpu_presets.csv").is_file() else sorted(out.glob("*/gpu_presets.csv"))
        if not tables:
            parser.error(f"--report: no {shown(out / 'gpu_presets.csv')} and no gpu_presets.csv in its folders")
        table = pd.concat([pd.read_csv(path) for path in tables], ignore_index=True)
        publish(out, "gpu_presets", table, markdown(table, args.cpu_run / "reports" / "fit_accuracy.csv"))
        return 0
    if args.preset is None:
        parser.error("--preset is required (unless --report)")
    if args.alone <= 0 and args.jobs <= 0:
        parser.error("nothing to run: give --alone or --jobs a count above 0")
    if args.variant == "cuda_ad_rgb" and args.collect is None and not cuda_available():
        raise SystemExit("gpu_presets: error: no CUDA GPU that Dr.Jit can start on this machine")
    if not (ROOT / "config" / "presets" / f"{args.preset}.yaml").is_file():
        raise SystemExit(f"gpu_presets: error: no preset {args.preset!r} in config/presets/")
    run = Run(args.preset, args.variant)
    images = pd.read_csv(write_sheet(args.images.split(","), out / f"{run.name}.samples.tsv"), sep="\t", dtype=str)["image_id"].tolist()
    parts = []
    started = time.perf_counter()
    if args.collect is not None:
        rows = mode_rows(out / run.name, run, images, args.jobs, args.collect, False)
        parts.append(rows.assign(mode="sheet", device=args.device or rows["device"]))
    elif args.alone > 0:
        alone = run_mode(out / f"{run.name}-alone", run, images[:: max(len(images) // args.alone, 1)][: args.alone], 1,
                         args.budget_s, False)
        parts.append(alone.assign(mode="alone"))
    remaining = args.budget_s - (time.perf_counter() - started)
    if args.jobs > 0 and args.collect is None:
        parts.append(run_mode(out / run.name, run, images, args.jobs, remaining, True).assign(mode="sheet"))
    table = pd.concat(parts, ignore_index=True)
    previous = out / "gpu_presets.csv"
    if previous.is_file():
        earlier = pd.read_csv(previous)
        kept = earlier[(earlier["preset"] != run.preset) | (earlier["variant"] != run.variant) | ~earlier["mode"].isin(table["mode"])]
        table = pd.concat([kept, table], ignore_index=True)
    publish(out, "gpu_presets", table, markdown(table, args.cpu_run / "reports" / "fit_accuracy.csv"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
