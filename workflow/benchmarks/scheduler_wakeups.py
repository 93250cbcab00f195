"""Benchmark: the default run with Snakemake's scheduler as it comes and with one pending wake-up.

    .venv/bin/python workflow/benchmarks/scheduler_wakeups.py [--images all] [--target all] [--order snakemake,one] [--out results/bench/scheduler_wakeups] [--report]

Runs ``snakemake --cores 2 <target>`` on the sample sheet into ``<out>/<variant>/``, one variant
after the other: ``snakemake``, the scheduler as Snakemake 9 has it (every pass of its loop starts
another wake-up timer), and ``one``, the workflow's own (``clothscope.core.scheduler``: one pending
wake-up at most). Reports per variant the run's wall seconds, the CPU seconds of the Snakemake
process itself (its jobs are separate processes), the timers it started, and the fit jobs' seconds
from their ``benchmark:`` files; and whether the two runs wrote the same fitted feature table and
the same classifier of record.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
from harness import ROOT, STAGES, fit_costs, fresh_run, publish, shown

#: the Snakemake process, with the workflow's scheduler change undone for ``snakemake``; writes its own CPU seconds
#: and the timers it started to the file named by CLOTHSCOPE_SCHEDULER_STATS when it exits
DRIVER = """
import atexit, json, os, runpy, sys, threading
if sys.argv[1] == "snakemake":
    import clothscope.core.scheduler as scheduler
    scheduler.keep_one_scheduler_wakeup = lambda: False
timers = [0]
start = threading.Timer.start
def counted_start(self):
    timers[0] += 1
    start(self)
threading.Timer.start = counted_start
def write_stats():
    t = os.times()
    with open(os.environ["CLOTHSCOPE_SCHEDULER_STATS"], "w") as stream:
        json.dump({"cpu_s": t.user + t.system, "timers": timers[0]}, stream)
atexit.register(write_stats)
sys.argv = ["snakemake", *sys.argv[2:]]
runpy.run_module("snakemake", run_name="__main__", alter_sys=True)
"""

VARIANTS = {"snakemake": "Snakemake's scheduler as it comes", "one": "one pending wake-up (the workflow's default)"}


def run_variant(variant: str, results: Path, sheet_images: list[str] | None, target: str) -> dict:
    """Run the workflow with ``variant``'s scheduler into the emptied ``results``; the run's figures."""
    sheet = fresh_run(results, sheet_images)
    stats = results / "scheduler_stats.json"
    command = [sys.executable, "-c", DRIVER, variant, "--cores", "2", "--quiet", "--config", f"samples={sheet}",
               f"results={results}", "--", str(results / target) if "/" in target else target]
    started = time.perf_counter()
    subprocess.run(command, cwd=ROOT, env=dict(os.environ, CLOTHSCOPE_SCHEDULER_STATS=str(stats)), check=True)
    wall = time.perf_counter() - started
    images = pd.read_csv(sheet, sep="\t", dtype=str)["image_id"].tolist()
    costs = pd.DataFrame([fit_costs(results, image) for image in images])
    own = json.loads(stats.read_text())
    return {"variant": variant, "images": len(images), "wall_s": round(wall, 1), "snakemake_cpu_s": round(own["cpu_s"], 1),
            "timers_started": own["timers"], "median_fit_s": costs["fit_s"].median(),
            **{f"median_{stage}_s": costs[f"{stage}_s"].median() for stage in STAGES},
            "fit_jobs_s": round(float(costs[[f"{stage}_s" for stage in STAGES]].sum().sum()), 1), "results": shown(results)}


def same_outputs(first: Path, second: Path) -> list[str]:
    """Lines on whether two runs wrote the same fitted feature table and the same predictions of the classifier of record."""
    lines = []
    for table in (Path("features/fitted/table.parquet"), Path("reports/fitted/predictions.csv")):
        if (first / table).is_file() and (second / table).is_file():
            read = pd.read_parquet if table.suffix == ".parquet" else pd.read_csv
            a, b = (read(run / table).sort_values("image_id").reset_index(drop=True) for run in (first, second))
            lines.append(f"- `{table}`: {'identical' if a.equals(b) else 'DIFFERENT'} in the two runs")
    record = Path("reports/fitted/accuracy.json")
    if (first / record).is_file() and (second / record).is_file():
        a, b = (json.loads((run / record).read_text()) for run in (first, second))
        lines.append(f"- classifier of record: {a['correct']}/{a['n']} and {b['correct']}/{b['n']}")
    return lines


def markdown(table: pd.DataFrame, target: str, checks: list[str]) -> str:
    """The figures per variant, with how they were measured."""
    lines = ["# Snakemake's scheduler: a wake-up chain per job event against one pending wake-up", "",
             f"`snakemake --cores 2 {target}` on {int(table['images'].iloc[0])} images, each variant into a fresh folder "
             "(the prepared photos copied from `results/prepared` where it exists, so `prepare` does not rerun), "
             "one after the other on the same machine (Dr.Jit's kernel cache warm). `snakemake_cpu_s`: CPU seconds of the "
             "Snakemake process itself (scheduling; the jobs are processes of their own); `timers_started`: wake-up timers "
             "it started; fit seconds from the fit rules' `benchmark:` files (two jobs side by side).", ""]
    lines += [f"- `{name}`: {text}" for name, text in VARIANTS.items()]
    lines += ["", table.drop(columns=["results"]).to_markdown(index=False), "", *checks, ""]
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", default="all", help="comma-separated image ids of config/samples.tsv, or all")
    parser.add_argument("--target", default="all", help="Snakemake target (a rule name, or a path under the run's folder)")
    parser.add_argument("--order", default="snakemake,one", help="the variants in the order they run")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench" / "scheduler_wakeups")
    parser.add_argument("--report", action="store_true", help="only rewrite the report from <out>/scheduler_wakeups.csv and the runs")
    args = parser.parse_args()
    order = args.order.split(",")
    if sorted(order) != sorted(VARIANTS):
        parser.error(f"--order: name each of {', '.join(VARIANTS)} once")
    images = None if args.images == "all" else args.images.split(",")
    out = args.out.resolve()
    if args.report:
        table = pd.read_csv(out / "scheduler_wakeups.csv")
        order = table["variant"].tolist()
    else:
        table = pd.DataFrame([run_variant(variant, out / variant, images, args.target) for variant in order])
    publish(out, "scheduler_wakeups", table, markdown(table, args.target, same_outputs(out / order[0], out / order[1])))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
