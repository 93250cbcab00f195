"""Benchmark: where a fit job's seconds go: process start and imports, set-up and writing, first iteration, iterations.

    .venv/bin/python workflow/benchmarks/job_costs.py [--run results] [--repeats 3]

Reads a finished run: each fit job's wall time (the rule's ``benchmark:`` file) and
its loss curves (``loss.csv``: seconds since each loop started, per iteration). The
loops' time is split into the first iteration's excess over a steady one (tracing
and compiling kernels the cache does not hold) and the steady iterations; what is
left of the wall time is outside the loops. Of that, the fixed start-up of a job
process is measured here directly, in fresh interpreters (``--repeats`` times,
median): the interpreter alone, importing the fit package, and loading Mitsuba's
LLVM variant. The remainder is the job's own set-up and writing (reading inputs,
building the scene, the effects plan, the preview render, the output files).
The run's figures include whatever the jobs shared their cores with when they
ran (the default profile runs two side by side on two cores); the start-up
figures are taken now, so run it on an otherwise idle machine.

It also refits one image (``--kernel-image``) in this process, alone on two
threads, with Dr.Jit's kernel history on, and splits each stage's job into the
time its kernels ran and the rest (tracing, Python, host-side work such as the
Large Steps solves, reading and writing). The rest bounds what recording and
replaying the loop's kernels (``dr.freeze``) could save. Writes ``results/bench/job_costs.{csv,md}``.
"""
from __future__ import annotations

import argparse
import logging
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from harness import ROOT, STAGES, publish, shown, validated_config

from clothscope.fit.outputs import LOSS_FILE

#: Python snippets of the start-up steps, each run in a fresh interpreter
START_UP = {
    "interpreter": "pass",
    "import the fit package": "import clothscope.fit.jobs",
    "import the fit package and load Mitsuba (llvm_ad_rgb, 1 thread)":
        "import clothscope.fit.jobs\nfrom clothscope.core.runtime import mitsuba_for\nmitsuba_for('llvm_ad_rgb', 1)",
}


def fresh_interpreter_seconds(code: str, repeats: int) -> float:
    """Median wall seconds of ``python -c code`` in a new process."""
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True, cwd=ROOT)
        times.append(time.perf_counter() - started)
    return statistics.median(times)


def loop_costs(curve: pd.DataFrame) -> dict[str, float]:
    """Iterations, loop seconds, the first iteration's excess over a steady one, and a steady iteration's seconds.

    A loss curve's ``seconds`` is taken after each forward pass, before its
    backward pass and step (:mod:`clothscope.fit.loop`): ``seconds[1]`` spans the
    first forward, backward and step and the second forward, two iterations'
    worth. A steady iteration is the median of the later intervals; the last
    backward pass and step come after the last entry and are counted as one.
    """
    iterations = loops = excess = 0.0
    steady_times = []
    for _, phase in curve.groupby("phase", sort=False):
        seconds = phase["seconds"].to_numpy()
        intervals = np.diff(seconds)
        steady = float(np.median(intervals[1:])) if len(intervals) > 1 else float(seconds[-1]) / len(seconds)
        iterations += len(seconds)
        loops += float(seconds[-1]) + steady
        if len(seconds) > 1:
            excess += max(float(seconds[1]) - 2.0 * steady, 0.0)
        steady_times.append(steady)
    return {"iterations": iterations, "loops_s": loops, "first_iteration_excess_s": excess,
            "steady_iteration_s": float(np.average(steady_times, weights=curve.groupby("phase", sort=False).size()))}


def job_rows(run: Path) -> pd.DataFrame:
    """One row per fitted image and stage of a run."""
    rows = []
    for stage in STAGES:
        for bench in sorted((run / "benchmarks" / f"fit_{stage}").glob("*.tsv")):
            curve_file = run / "fit" / bench.stem / stage / LOSS_FILE
            if not curve_file.exists():
                continue
            wall = float(pd.read_csv(bench, sep="\t").iloc[-1]["s"])
            costs = loop_costs(pd.read_csv(curve_file))
            rows.append({"image_id": bench.stem, "stage": stage, "wall_s": wall, **costs,
                         "steady_loops_s": costs["loops_s"] - costs["first_iteration_excess_s"],
                         "outside_loops_s": max(wall - costs["loops_s"], 0.0)})
    return pd.DataFrame(rows)


def summary(jobs: pd.DataFrame, start_up: dict[str, float]) -> pd.DataFrame:
    """Median per stage of each part of a job's wall time."""
    launch = start_up[list(START_UP)[-1]]
    rows = []
    for stage, group in jobs.groupby("stage", sort=False):
        med = group.median(numeric_only=True)
        rows.append({"stage": stage, "jobs": len(group), "wall s": med["wall_s"],
                     "start-up (measured) s": launch,
                     "set-up and writing s": max(med["outside_loops_s"] - launch, 0.0),
                     "first iteration excess s": med["first_iteration_excess_s"],
                     "steady iterations s": med["steady_loops_s"],
                     "iterations": med["iterations"], "per iteration ms": 1000 * med["steady_iteration_s"]})
    return pd.DataFrame(rows)


def kernel_split(image: str, results: Path) -> pd.DataFrame:
    """Refit ``image`` (its prepared folder under ``results``) stage by stage here; per stage: wall, kernel and other seconds.

    Mitsuba is loaded before the first stage, so no stage's wall time holds the import. Kernel
    seconds are Dr.Jit's execution times; compiling a kernel the cache lacks counts as other time
    and is also given on its own.
    """
    import drjit as dr

    from clothscope.core.runtime import mitsuba_for
    from clothscope.fit import jobs
    from clothscope.fit.geometry import GeometrySettings
    from clothscope.fit.material import MaterialSettings
    from clothscope.fit.normals import NormalSettings

    config = validated_config()
    fit = config["fit"]
    common = dict(variant=config["variant"], threads=2, full_effects=fit["full_effects"], log=logging.getLogger("job_costs"),
                  sample_seed=fit["sample_seed"])
    mitsuba_for(config["variant"], 2)
    prepared = str(results / "prepared" / image)
    rows = []
    with tempfile.TemporaryDirectory() as tmp, dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
        out = {stage: str(Path(tmp) / stage) for stage in STAGES}
        calls = {"geometry": lambda: jobs.geometry_job(prepared, out["geometry"], GeometrySettings(**fit["geometry"]), **common),
                 "material": lambda: jobs.material_job(prepared, out["geometry"], out["material"],
                                                       MaterialSettings(**fit["material"]), **common),
                 "normals": lambda: jobs.normals_job(prepared, out["material"], out["normals"],
                                                     NormalSettings(**fit["normals"]), **common)}
        for stage in STAGES:
            dr.kernel_history_clear()
            started = time.perf_counter()
            record = calls[stage]()
            wall = time.perf_counter() - started
            if record.get("status") != "fitted":
                raise SystemExit(f"{image}: the {stage} refit did not finish: {record.get('status')}: {record.get('reason', '')}")
            history = dr.kernel_history()
            kernels = sum(entry.get("execution_time", 0.0) for entry in history) / 1000.0
            compiling = sum(entry.get("codegen_time", 0.0) + entry.get("backend_time", 0.0) for entry in history) / 1000.0
            iterations = len(pd.read_csv(Path(out[stage]) / LOSS_FILE))
            rows.append({"stage": stage, "wall s": wall, "kernels s": kernels, "other s": wall - kernels,
                         "of which compiling s": compiling, "iterations": iterations,
                         "other over iterations ms": 1000 * (wall - kernels) / iterations})
    return pd.DataFrame(rows)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", type=Path, default=ROOT / "results")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--kernel-image", default="canvas_red", help="image refitted to split kernel time from the rest")
    args = parser.parse_args()
    jobs = job_rows(args.run)
    if jobs.empty:
        raise SystemExit(f"no fitted jobs with loss curves under {args.run}: run the workflow first")
    start_up = {name: fresh_interpreter_seconds(code, args.repeats) for name, code in START_UP.items()}
    table = summary(jobs, start_up)
    lines = [f"Medians over {jobs['image_id'].nunique()} images of `{shown(args.run)}` "
             "(as its jobs ran; the default profile runs two side by side on two cores).", "",
             table.to_markdown(index=False, floatfmt=".2f"), "",
             f"Start-up of a job process, measured in fresh interpreters (median of {args.repeats}):", ""]
    lines += [f"- {name}: {seconds:.2f} s" for name, seconds in start_up.items()]
    total = table["wall s"].sum()
    fixed = (table["start-up (measured) s"] + table["set-up and writing s"] + table["first iteration excess s"]).sum()
    lines += ["", f"Of the three stages' median wall time ({total:.1f} s), {fixed:.1f} s ({fixed / total:.0%}) is fixed cost "
              "(start-up, set-up and writing, first-iteration excess); the rest is steady iterations."]
    split = kernel_split(args.kernel_image, args.run)
    other = split["other s"].sum() / split["wall s"].sum()
    lines += ["", f"`{args.kernel_image}` refitted in one process, alone on two threads, with Dr.Jit's kernel history "
              "(the jobs' own wall time, without process start-up or loading Mitsuba; other time includes each job's set-up "
              "and writing):", "", split.to_markdown(index=False, floatfmt=".2f"), "",
              f"Kernels ran {1 - other:.0%} of the three jobs' time; the other {other:.0%} (tracing, Python, host-side "
              "work such as the Large Steps solves, reading and writing) bounds what recording and replaying the loops' kernels (`dr.freeze`) could save."]
    publish(args.out, "job_costs", jobs, "\n".join(lines) + "\n", float_format="%.4g")


if __name__ == "__main__":
    main()
