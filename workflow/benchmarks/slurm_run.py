"""Benchmark: the same small run through the local executor and through ``workflow/profiles/slurm``; wall time and outputs.

Runs the three-image sheet (``--images``) to ``features/fitted/table.parquet`` with ``preset=fast``, once with
``--cores 2`` and once with the Slurm profile, each into a fresh results folder under ``--work``, then compares
the two feature tables and every ``fit/<image>/<stage>/material.json``. Needs root, a live Slurm controller
(``bash workflow/cluster/single_node_slurm.sh``) and the executor plugin (``bash bootstrap.sh --slurm``).

    .venv/bin/python workflow/benchmarks/slurm_run.py [--images broadcloth_red,satin_red,velvet_red] [--init-seconds 10]
        [--work results/bench/slurm_work]

Writes ``results/bench/slurm.{csv,md}``; the runs' logs stay in ``--work``.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from harness import ROOT, publish, shown, write_sheet

TARGET = Path("features") / "fitted" / "table.parquet"


def check_cluster() -> None:
    """Exit with one line unless this runs as root, ``sinfo -h`` answers and the executor plugin is installed."""
    start = "run `bash workflow/cluster/single_node_slurm.sh` first"
    if os.geteuid() != 0:
        raise SystemExit(f"slurm_run: must run as root (the local cluster runs jobs as root); {start} and run this as root")
    if shutil.which("sinfo") is None or subprocess.run(["sinfo", "-h"], check=False, capture_output=True, timeout=60).returncode != 0:
        raise SystemExit(f"slurm_run: no Slurm controller answers `sinfo -h`; {start}")
    if importlib.util.find_spec("snakemake_executor_plugin_slurm") is None:
        raise SystemExit("slurm_run: the Slurm executor plugin is missing; run `bash bootstrap.sh --slurm` first")


def run(name: str, executor: list[str], sheet: Path, work: Path) -> tuple[Path, float, str]:
    """Run Snakemake with ``executor`` into a fresh ``work/<name>``; (results folder, wall seconds, log text)."""
    results = work / name
    shutil.rmtree(results, ignore_errors=True)
    command = [sys.executable, "-m", "snakemake", *executor, "--config", f"samples={sheet}", f"results={results}",
               "preset=fast", "--", str(results / TARGET)]
    started = time.perf_counter()
    done = subprocess.run(command, check=False, cwd=ROOT, capture_output=True, text=True)
    seconds = time.perf_counter() - started
    log = done.stdout + done.stderr
    (work / f"{name}.log").write_text(log)
    if done.returncode != 0:
        raise SystemExit(f"slurm_run: the {name} run failed (exit {done.returncode}); see {work / f'{name}.log'}")
    return results, seconds, log


def jobs_done(log: str) -> int:
    """The number of jobs Snakemake reports as done ("N of N steps (100%) done"); 0 when nothing had to run."""
    counts = re.findall(r"(\d+) of \d+ steps \(100%\) done", log)
    return int(counts[-1]) if counts else 0


def compare_tables(local: Path, slurm: Path) -> list[str]:
    """Lines comparing the two feature tables: rows, columns, max abs difference over numeric columns, bytes."""
    a, b = (pd.read_parquet(path).sort_values("image_id").reset_index(drop=True) for path in (local, slurm))
    lines = [(f"- `{TARGET}`: local {a.shape[0]} rows x {a.shape[1]} columns, Slurm {b.shape[0]} x {b.shape[1]}; "
              f"same image ids: {list(a['image_id']) == list(b['image_id'])}")]
    if a.shape == b.shape and list(a.columns) == list(b.columns):
        numeric = a.select_dtypes("number").columns
        x, y = a[numeric].to_numpy(float), b[numeric].to_numpy(float)
        same_nan = bool((np.isnan(x) == np.isnan(y)).all())
        diff = float(np.nanmax(np.abs(x - y))) if np.isfinite(x - y).any() else 0.0
        other = a.drop(columns=numeric).astype(str).equals(b.drop(columns=numeric).astype(str))
        lines.append(f"- {len(numeric)} numeric columns: max abs difference {diff:.3g}, same NaN positions: {same_nan}; "
                     f"other columns equal: {other}")
    lines.append(f"- byte-identical table: {local.read_bytes() == slurm.read_bytes()}")
    return lines


def compare_materials(local: Path, slurm: Path) -> list[str]:
    """Lines comparing every ``fit/<image>/<stage>/material.json`` of the local run with the Slurm run's."""
    files = sorted(path.relative_to(local) for path in local.glob("fit/*/*/material.json"))
    missing = [str(path) for path in files if not (slurm / path).exists()]
    same_bytes = sum((local / path).read_bytes() == (slurm / path).read_bytes() for path in files if (slurm / path).exists())
    same_json = sum(json.loads((local / path).read_text()) == json.loads((slurm / path).read_text())
                    for path in files if (slurm / path).exists())
    stages = sorted({path.parts[2] for path in files})
    return [f"- `fit/<image>/{{{','.join(stages)}}}/material.json`: {len(files)} files, {same_bytes} byte-identical, "
            f"{same_json} equal as JSON" + (f"; missing in the Slurm run: {', '.join(missing)}" if missing else "")]


def slurm_memory(log: str) -> list[str]:
    """Per-rule max sacct MaxRSS (MiB) of the batch step (outer Snakemake) and the srun step (rule); [] if unavailable."""
    rules = dict(re.findall(r"submitted with SLURM jobid (\d+) \(log: \S*?/slurm_logs/(?:rule_)?([\w-]+)/", log))
    if not rules or shutil.which("sacct") is None:
        return []
    done = subprocess.run(["sacct", "-n", "-P", "--units=M", "-o", "JobID,MaxRSS,Elapsed", "-j", ",".join(rules)],
                          check=False, capture_output=True, text=True)
    peaks: dict[str, dict[str, float]] = {}
    for line in done.stdout.splitlines():
        job_id, rss, _ = (line.split("|") + ["", ""])[:3]
        parent, _, step = job_id.partition(".")
        if parent in rules and step in ("batch", "0") and rss.rstrip("M"):
            entry = peaks.setdefault(rules[parent], {"batch": 0.0, "0": 0.0})
            entry[step] = max(entry[step], float(rss.rstrip("M")))
    if not peaks:
        return []
    lines = ["", "| rule | Slurm jobs | max MaxRSS batch step (MiB) | max MaxRSS srun step (MiB) |", "|---|---|---|---|"]
    counts = pd.Series(list(rules.values())).value_counts()
    return lines + [f"| {rule} | {counts[rule]} | {p['batch']:.0f} | {p['0']:.0f} |" for rule, p in sorted(peaks.items())]


def machine() -> str:
    """CPUs, memory and the current load average of this machine, in words."""
    mem_kib = int(re.search(r"MemTotal:\s+(\d+)", Path("/proc/meminfo").read_text()).group(1))
    return f"{os.cpu_count()} CPUs, {mem_kib / 2**20:.1f} GiB memory, load average {os.getloadavg()[0]:.2f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--images", default="broadcloth_red,satin_red,velvet_red")
    parser.add_argument("--init-seconds", type=int, default=10,
                        help="--slurm-init-seconds-before-status-checks (default 10; 0 keeps the plugin's default)")
    parser.add_argument("--work", type=Path, default=ROOT / "results" / "bench" / "slurm_work")
    args = parser.parse_args()
    check_cluster()
    work = args.work.resolve()
    sheet = write_sheet(args.images.split(","), work / "samples.tsv")
    before = machine()
    slurm_flags = ["--profile", "workflow/profiles/slurm"]
    if args.init_seconds > 0:
        slurm_flags += ["--slurm-init-seconds-before-status-checks", str(args.init_seconds)]
    local, local_s, local_log = run("local", ["--cores", "2"], sheet, work)
    slurm, slurm_s, slurm_log = run("slurm", slurm_flags, sheet, work)
    frame = pd.DataFrame([{"run": "local --cores 2", "jobs": jobs_done(local_log), "wall_s": local_s},
                          {"run": " ".join(slurm_flags), "jobs": jobs_done(slurm_log), "wall_s": slurm_s}])
    lines = ["# One small run: local executor vs the Slurm profile", "",
             (f"Images {args.images} (`preset=fast`), target `<results>/{TARGET}`, each run into a fresh folder under "
              f"`{shown(work)}`."),
             (f"Machine: {before} at the start, {machine().split(', ')[-1]} at the end. The Slurm cluster runs on this same "
              "machine, so the figures depend on its load and on the executor's polling, not on cluster capacity."), "",
             "| run | jobs | wall s |", "|---|---|---|"]
    lines += [f"| `{r.run}` | {r.jobs} | {r.wall_s:.1f} |" for r in frame.itertuples()]
    lines += ["", f"Slurm / local wall time: {slurm_s / local_s:.2f}x.", "", "## Outputs compared", ""]
    lines += compare_tables(local / TARGET, slurm / TARGET) + compare_materials(local, slurm)
    memory = slurm_memory(slurm_log)
    if memory:
        lines += ["", "## Memory of the Slurm jobs (sacct)"] + memory
    publish(ROOT / "results" / "bench", "slurm", frame, "\n".join(lines) + "\n", float_format="%.2f")


if __name__ == "__main__":
    main()
