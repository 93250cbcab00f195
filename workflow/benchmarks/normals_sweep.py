"""Benchmark: what the normal-map stage's knobs buy in roughness, on every image, from the cached material stage.

Only ``fit_normals`` reruns, from ``results/fit/<id>/material`` of the main
workflow run (run ``snakemake`` first), one Dr.Jit thread per image and two
images side by side, as the workflow runs them. Each variant is the config's
``fit.normals`` with a few knobs overridden; the roughness it returns is scored
against the synthetic ground truth. Nothing is written into the main results.

    .venv/bin/python workflow/benchmarks/normals_sweep.py [--variants default,spp-4-4,...] [--images all]

Writes ``results/reports/normals_sweep.csv`` (one row per image and variant) and
``results/reports/normals_sweep.md`` (median roughness error, images within
0.05 and median normal-map stage seconds per variant).
"""
from __future__ import annotations

import argparse
import json
import multiprocessing
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from harness import ROOT, SUBSET, publish, validated_config, write_sheet

#: variant -> overrides of the config's fit.normals
VARIANTS: dict[str, dict] = {
    "default": {},
    "independent-16-2": {"sampler": "independent", "spp": 16},  # the default before the samples were stratified
    "spp-16-2": {"spp": 16},
    "spp-8-2": {"spp": 8},
    "large-steps": yaml.safe_load((ROOT / "config" / "overlays" / "large_steps.yaml").read_text())["fit"]["normals"],
    "spp-4-4": {"spp": 4, "spp_grad": 4},  # the sample counts before the loss image took more than the gradient pass
    "spp-4-8": {"spp": 4, "spp_grad": 8},
    "spp-8-4": {"spp": 8, "spp_grad": 4},
    "spp-8-8": {"spp": 8, "spp_grad": 8},
    "spp-16-4": {"spp": 16, "spp_grad": 4},
    "spp-8-4-joint-300": {"spp": 8, "spp_grad": 4, "joint_iterations": 300},
    "spp-4-4-joint-400": {"spp": 4, "spp_grad": 4, "joint_iterations": 400},
    "spp-4-4-joint-lr-0.04": {"spp": 4, "spp_grad": 4, "joint_learning_rate": 0.04},
    # cheaper steps or fewer of them (issue 18's time target)
    "spp-2-2": {"spp": 2},
    "spp-4-1": {"spp_grad": 1},
    "joint-140": {"joint_iterations": 140},
}


def normal_settings(overrides: dict) -> dict:
    """The workflow's ``fit.normals`` (preset merged, schema defaults filled in, as ``common.smk`` does) with ``overrides``."""
    return validated_config()["fit"]["normals"] | overrides


def fit_one(job: tuple[str, str, dict]) -> dict:
    """Rerun ``fit_normals`` of one image from its material stage; its fitted and true roughness and seconds."""
    import logging

    from clothscope.core.runtime import mitsuba_for
    from clothscope.fit.colour import choose_colour_model
    from clothscope.fit.effects import geometry_evidence, plan_stage
    from clothscope.fit.normals import NormalSettings, fit_normals, relief_prior
    from clothscope.fit.outputs import load_state
    from clothscope.fit.target import at_resolution, load_prepared

    image, fabric_class, settings = job
    mi = mitsuba_for("llvm_ad_rgb", 1)
    truth = json.loads((ROOT / "data" / "synthetic" / fabric_class / f"{image}.truth.json").read_text())
    fit, _ = load_state(ROOT / "results" / "fit" / image / "material")
    photo = load_prepared(ROOT / "results" / "prepared" / image)
    plan = plan_stage("normals", geometry_evidence(fit.grid, fit.camera, fit.light))
    knobs, _ = relief_prior(NormalSettings(**settings), fit.light)  # as the fit_normals job chooses its prior
    started = time.perf_counter()
    colour = choose_colour_model(knobs.colour_model, photo.image, knobs.texture, fit.margin, knobs.layout_mixing)
    _, material, _, _ = fit_normals(mi, fit, at_resolution(photo, settings["resolution"]), plan, knobs,
                                 logging.getLogger("normals_sweep"), colour, validated_config()["fit"]["sample_seed"])
    return {"image_id": image, "fabric_class": fabric_class, "roughness": material.roughness,
            "roughness_true": truth["roughness"], "roughness_error": abs(material.roughness - truth["roughness"]),
            "normals_s": time.perf_counter() - started}


def summary(table: pd.DataFrame) -> str:
    rows = table.groupby("variant", sort=False).agg(
        roughness_error=("roughness_error", "median"), within_005=("roughness_error", lambda e: int((e <= 0.05).sum())),
        images=("image_id", "count"), normals_s=("normals_s", "median"))
    rows.insert(0, "overrides of fit.normals", [json.dumps(VARIANTS[name]) for name in rows.index])
    return ("# Normal-map stage knobs: roughness error on the synthetic set\n\n"
            "Only `fit_normals` reruns, from the main run's material stage; 1 thread per image, 2 images side by side. "
            "Medians over the images; `within_005`: images whose roughness error is at most 0.05.\n\n"
            + rows.to_markdown(floatfmt=".4f") + "\n")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", default=",".join(VARIANTS))
    parser.add_argument("--images", default="all", help=f"comma-separated image ids or 'all' (one per class: {SUBSET})")
    args = parser.parse_args()
    names = args.variants.split(",")
    unknown = sorted(set(names) - set(VARIANTS))
    if unknown:
        raise SystemExit(f"normals_sweep: error: unknown variants {', '.join(unknown)} (known: {', '.join(VARIANTS)})")
    out = ROOT / "results" / "reports"
    with tempfile.TemporaryDirectory() as folder:
        sheet = pd.read_csv(write_sheet(args.images.split(","), Path(folder) / "samples.tsv"), sep="\t", dtype=str)
    tables = []
    with multiprocessing.get_context("spawn").Pool(2) as pool:
        for name in names:
            settings = normal_settings(VARIANTS[name])
            rows = pool.map(fit_one, [(row.image_id, row.fabric_class, settings) for row in sheet.itertuples()])
            tables.append(pd.DataFrame(rows).assign(variant=name))
            print(f"{name}: median roughness error {np.median([r['roughness_error'] for r in rows]):.4f}", flush=True)
    table = pd.concat(tables, ignore_index=True)
    publish(out, "normals_sweep", table, summary(table), float_format="%.5f")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
