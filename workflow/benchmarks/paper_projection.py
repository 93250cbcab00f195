"""Benchmark: projected fit time per image of the ``paper`` preset, from measured per-iteration costs.

The ``paper`` preset is too slow to run on the whole set on 2 CPU cores, so
this script measures it the cheap way: it fits one image through the real
workflow with the ``paper`` preset twice, with every stage capped at
``--short`` and at ``--long`` iterations (the stopping rules of the preset
are off, so each stage runs exactly that many), reads the per-stage wall
time from the rules' ``benchmark:`` files, and fits ``seconds = fixed +
per_iteration * iterations`` per stage. The projection is that line at the
preset's own iteration counts. Jobs run with the configured ``fit.threads``
(1 by default), the same as the default preset's timings in
``results/reports/fit_accuracy.csv``.

    .venv/bin/python workflow/benchmarks/paper_projection.py [--image broadcloth_red] [--short 3] [--long 10]

Writes ``results/reports/paper_projection.{csv,md}``.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
import yaml
from harness import ROOT, STAGES, publish, seed_prepared, snakemake, stage_benchmarks

from clothscope.core.schema import deep_merge


def run_capped(image: str, iterations: int, out: Path) -> dict[str, float]:
    """Fit ``image`` with the paper preset and every stage capped at ``iterations``; seconds per stage."""
    results = out / f"capped-{iterations}"
    results.mkdir(parents=True, exist_ok=True)
    seed_prepared(results, image)
    # a preset's knobs win over config files, so the capped paper settings go in as an overlay on the default preset
    capped = deep_merge(paper_preset(), {"fit": {stage: {"iterations": iterations} for stage in STAGES}})
    overlay = results / "overlay.yaml"
    overlay.write_text(yaml.safe_dump(capped))
    snakemake(["--configfile", "config/config.yaml", str(overlay), "--config", "preset=default", f"results={results}",
               "--forcerun", "fit_geometry", "--quiet", "all", "--", str(results / "fit" / image / "normals")])
    return {stage: seconds for stage, (seconds, _) in stage_benchmarks(results, image).items()}


def paper_preset() -> dict:
    """The ``paper`` preset's knobs."""
    return yaml.safe_load((ROOT / "config" / "presets" / "paper.yaml").read_text(encoding="utf-8"))


def paper_iterations() -> dict[str, int]:
    """Iterations per stage of the paper preset (the joint phase is off there)."""
    return {stage: int(paper_preset()["fit"][stage]["iterations"]) for stage in STAGES}


def default_seconds(image: str) -> dict[str, float] | None:
    """Measured default-preset seconds per stage of ``image`` from the main results, when present."""
    table = ROOT / "results" / "reports" / "fit_accuracy.csv"
    if not table.exists():
        return None
    rows = pd.read_csv(table)
    rows = rows[rows["image_id"] == image]
    return None if rows.empty else {stage: float(rows.iloc[0][f"{stage}_s"]) for stage in STAGES}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--image", default="broadcloth_red")
    parser.add_argument("--short", type=int, default=3)
    parser.add_argument("--long", type=int, default=10)
    parser.add_argument("--out", default="results/bench/paper_projection")
    args = parser.parse_args()
    if not 0 < args.short < args.long:
        raise SystemExit("paper_projection: error: need 0 < --short < --long")
    out = (ROOT / args.out).resolve()
    short, long = run_capped(args.image, args.short, out), run_capped(args.image, args.long, out)
    target = paper_iterations()
    measured = default_seconds(args.image)
    rows = []
    for stage in STAGES:
        per_iteration = (long[stage] - short[stage]) / (args.long - args.short)
        fixed = max(short[stage] - per_iteration * args.short, 0.0)
        rows.append({"stage": stage, f"s_at_{args.short}_it": short[stage], f"s_at_{args.long}_it": long[stage],
                     "s_per_iteration": per_iteration, "fixed_s": fixed, "paper_iterations": target[stage],
                     "projected_s": fixed + per_iteration * target[stage],
                     "default_measured_s": measured[stage] if measured else float("nan")})
    table = pd.DataFrame(rows)
    total = table[["projected_s", "default_measured_s"]].sum()
    text = "\n".join([
        f"# Projected time of the `paper` preset ({args.image}, 1 image, `fit.threads` as configured)", "",
        f"Measured at {args.short} and {args.long} iterations per stage, projected linearly to the preset's counts.", "",
        table.round(3).to_markdown(index=False), "",
        f"Projected paper-preset fit: {total['projected_s']:.0f} s per image; default preset measured: "
        f"{total['default_measured_s']:.1f} s (ratio {total['default_measured_s'] / total['projected_s']:.4f}).", ""])
    publish(ROOT / "results" / "reports", "paper_projection", table, text, "%.4g")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
