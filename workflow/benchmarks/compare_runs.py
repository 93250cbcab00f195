"""Benchmark: do two finished runs hold the same results, file by file?

    .venv/bin/python workflow/benchmarks/compare_runs.py REFERENCE OTHER [--out results/bench/compare_runs]

Compares every file under ``prepared/``, ``fit/``, ``features/``, ``reports/``, ``models/`` and ``physics/``
of two results folders (for example the default run before and after a refactor, the other one made in
a ``git worktree`` of the newer commit): byte for byte, and where the bytes differ, by content (a CSV
without its wall-clock ``seconds`` column, Parquet value by value; :func:`rerun_identity.same_content`).
Run-level time and memory reports (``fit_accuracy``) differ between any two runs and are listed as such.
Writes ``<out>/compare_runs.{csv,md}``.
"""
from __future__ import annotations

import argparse
import filecmp
from pathlib import Path

import numpy as np
import pandas as pd
from harness import ROOT, publish
from rerun_identity import same_content

#: the folders of a run that hold results (logs and benchmarks hold times)
RESULT_FOLDERS = ("prepared", "fit", "features", "reports", "models", "physics")


def compare_file(reference: Path, other: Path, name: Path) -> dict:
    """One row: whether ``name`` exists in both runs, has identical bytes, identical content, and the largest numeric gap."""
    a, b = reference / name, other / name
    if not b.exists():
        return {"file": str(name), "in_other": False, "bytes": False, "content": False, "max_abs_diff": np.nan}
    identical = filecmp.cmp(a, b, shallow=False)
    content, gap = (True, 0.0) if identical else same_content(a, b)
    return {"file": str(name), "in_other": True, "bytes": identical, "content": content, "max_abs_diff": gap}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("reference", type=Path)
    parser.add_argument("other", type=Path)
    parser.add_argument("--out", default="results/bench/compare_runs")
    args = parser.parse_args()
    names = sorted(p.relative_to(args.reference) for folder in RESULT_FOLDERS if (args.reference / folder).is_dir()
                   for p in (args.reference / folder).rglob("*") if p.is_file())
    table = pd.DataFrame([compare_file(args.reference, args.other, name) for name in names])
    only_other = sorted(str(p.relative_to(args.other)) for folder in RESULT_FOLDERS if (args.other / folder).is_dir()
                        for p in (args.other / folder).rglob("*") if p.is_file() and not (args.reference / p.relative_to(args.other)).exists())
    differ = table[~table["content"]]
    lines = [f"# {args.reference} against {args.other}", "",
             f"{len(table)} files: {int(table['bytes'].sum())} byte-identical, {int((table['content'] & ~table['bytes']).sum())} "
             f"identical in content (times aside), {len(differ)} different or missing; {len(only_other)} only in {args.other}.", ""]
    if len(differ):
        lines += [differ.to_markdown(index=False), ""]
    lines += [f"- only in {args.other}: {name}" for name in only_other]
    publish((ROOT / args.out).resolve(), "compare_runs", table, "\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
