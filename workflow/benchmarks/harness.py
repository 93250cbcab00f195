"""What the benchmark scripts share: sample-sheet subsets, Snakemake runs, the rules' benchmark files and reports.

Imported by the scripts beside it (``from harness import ...``); not a benchmark itself.
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pandas as pd

from clothscope.classify.feature_sets import classifier_candidates, compare_feature_sets, joined_table, joined_tiles
from clothscope.classify.loocv import Choice, LoocvResult, loocv
from clothscope.core.atomic import write_text
from clothscope.core.config import FIT_STAGES
from clothscope.evaluate.accuracy import benchmark_seconds
from clothscope.features.sources import STATUS_OK

ROOT = Path(__file__).resolve().parents[2]
STAGES = FIT_STAGES
#: one image per class
SUBSET = "broadcloth_red,canvas_navy,satin_green,chiffon_mustard,cotton_gauze_ivory,knit_jersey_charcoal,velvet_ivory"
#: two images per class
TWO_PER_CLASS = ",".join(f"{c}_{d}" for c in ("broadcloth", "canvas", "satin", "chiffon", "cotton_gauze", "knit_jersey", "velvet")
                         for d in ("red", "ivory"))


def validated_config() -> dict:
    """``config/config.yaml`` with its preset merged and the schema's defaults filled in, as the workflow sees it."""
    import yaml

    from clothscope.core.config import SCHEMA_PATH
    from clothscope.core.schema import apply_preset, load_schema, validate

    config = apply_preset(yaml.safe_load((ROOT / "config" / "config.yaml").read_text()), ROOT / "config" / "presets")
    return validate(config, load_schema(SCHEMA_PATH), "config")


def declared_resources() -> dict[str, dict[str, float | str]]:
    """Each rule's ``mem_mb`` (MB) and ``runtime`` (minutes) as the workflow declares them with the default config;
    ``"per job"`` where the rule computes it from the job's input (``prepare``'s memory)."""
    from snakemake.api import SnakemakeApi
    from snakemake.settings.enums import Quietness
    from snakemake.settings.types import OutputSettings, ResourceSettings

    declared: dict[str, dict[str, float | str]] = {}
    with SnakemakeApi(OutputSettings(quiet={Quietness.ALL})) as api:
        workflow = api.workflow(resource_settings=ResourceSettings(cores=2), snakefile=ROOT / "Snakefile", workdir=ROOT)
        for rule in workflow._workflow.rules:  # the pinned Snakemake's rule objects; no public listing holds resources
            values = {name: rule.resources[name] for name in ("mem_mb", "runtime") if name in rule.resources}
            declared[rule.name] = {name: "per job" if value.is_evaluable() else float(value.value)
                                   for name, value in values.items()}
    return declared


def require_tables(run: Path, sources: tuple[str, ...] = ("fitted", "photo")) -> None:
    """Exit with one line naming the first of ``run``'s feature tables (``features/<source>/table.parquet``) that is missing."""
    for source in sources:
        path = run / "features" / source / "table.parquet"
        if not path.is_file():
            raise SystemExit(f"{shown(path)}: no such feature table; run the workflow into {shown(run)} first")


def run_tables(run: Path, sources: tuple[str, ...] = ("fitted", "photo")) -> tuple[dict[str, pd.DataFrame], dict[str, pd.DataFrame]]:
    """A run's feature tables by source, and its tile tables (``features/<source>/tiles/table.parquet``) where written."""
    require_tables(run, sources)
    tables = {s: pd.read_parquet(run / "features" / s / "table.parquet") for s in sources}
    tiles = {s: pd.read_parquet(run / "features" / s / "tiles" / "table.parquet") for s in sources
             if (run / "features" / s / "tiles" / "table.parquet").is_file()}
    return tables, tiles


def record_inputs(tables: dict[str, pd.DataFrame], tile_tables: dict[str, pd.DataFrame] | None,
                  feature_set: str) -> tuple[pd.DataFrame, pd.DataFrame | None, dict[str, list[str]]]:
    """What the ``classify`` rule's LOOCV reads from a run's fitted and photo tables: the usable joined rows,
    their tile rows (None without tile tables) and the candidate column sets of ``feature_set``."""
    sources = {s: tables[s] for s in ("fitted", "photo")}
    joined = joined_table(sources)
    return (joined[joined["status"] == STATUS_OK], joined_tiles(sources, tile_tables),
            classifier_candidates(feature_set, "fitted", joined.columns))


def record_loocv(rows: pd.DataFrame, candidates: dict[str, list[str]], tiles: pd.DataFrame | None, settings: dict,
                 **options) -> LoocvResult:
    """The classifier of record's LOOCV over ``rows`` with the config's ``classify`` ``settings`` (shrinkage, subspace,
    choice, test tiles, whether it votes and its pruning); ``options`` go to :func:`clothscope.classify.loocv.loocv`
    (``score``, or ``choice``, ``test_tiles``, ``vote`` or ``prune`` to replace the config's)."""
    return loocv(rows, [], settings["reg"], select_from=candidates, subspace=settings["subspace"], tiles=tiles,
                 **record_options(settings, **options))


def record_options(settings: dict, **options) -> dict:
    """``options`` for :func:`clothscope.classify.loocv.loocv`, with the classifier of record's ``choice``, ``vote``,
    ``prune`` and ``test_tiles`` taken from the config's ``classify`` ``settings`` where not given."""
    options.setdefault("choice", Choice.from_config(settings["choice"]))
    options.setdefault("vote", settings["feature_set"] == "vote")
    options.setdefault("prune", settings["prune"] if options["vote"] else 0.0)
    options.setdefault("test_tiles", settings["test_tiles"] == "mean")
    return options


def write_sheet(images: list[str] | None, target: Path, source: Path = ROOT / "config" / "samples.tsv") -> Path:
    """Write the rows of the sample sheet ``source`` for ``images`` (None or ``["all"]``: every row) to ``target``."""
    sheet = pd.read_csv(source, sep="\t", dtype=str, keep_default_na=False)
    if images is not None and images != ["all"]:
        missing = sorted(set(images) - set(sheet["image_id"]))
        if missing:
            raise SystemExit(f"{Path(sys.argv[0]).stem}: error: not in {shown(source)}: {', '.join(missing)}")
        sheet = sheet[sheet["image_id"].isin(images)]
    target.parent.mkdir(parents=True, exist_ok=True)
    sheet.to_csv(target, sep="\t", index=False)
    return target


def shown(path: Path) -> str:
    """``path`` relative to the repository root when it is inside it, else as it is (for reports)."""
    try:
        return str(path.resolve().relative_to(ROOT))
    except ValueError:
        return str(path)


def publish(folder: Path, name: str, table: pd.DataFrame, text: str, float_format: str | None = None) -> None:
    """Write ``<name>.csv`` (the table) and ``<name>.md`` (the text) into ``folder`` atomically, and print the text."""
    write_text(folder / f"{name}.csv", table.to_csv(index=False, float_format=float_format))
    write_text(folder / f"{name}.md", text)
    print(text)


def change_lines(table: pd.DataFrame, before: str, after: str) -> list[str]:
    """Markdown tables of images right in columns ``before`` and ``after`` (of ``n``), per ``run`` and
    ``feature_set`` and then summed over the runs, with the change."""
    lines = [f"| run | feature set | {before} | {after} | change |", "|---|---|---|---|---|"]
    lines += [f"| `{r['run']}` | {r['feature_set']} | {r[before]}/{r['n']} | {r[after]}/{r['n']} | {r[after] - r[before]:+d} |"
              for _, r in table.iterrows()]
    total = table.groupby("feature_set", sort=False)[[before, after, "n"]].sum()
    lines += ["", "Summed over the runs:", "", f"| feature set | {before} | {after} | change |", "|---|---|---|---|"]
    lines += [f"| {name} | {r[before]}/{r['n']} | {r[after]}/{r['n']} | {r[after] - r[before]:+d} |" for name, r in total.iterrows()]
    return lines


def sets_and_record(tables: dict[str, pd.DataFrame], tiles: dict[str, pd.DataFrame], settings: dict,
                    keep: Callable[[str], bool], test_tiles: bool = False) -> list[dict]:
    """Images right of the feature-set report's sets whose name ``keep`` accepts, and of the classifier of record,
    each fold also training on ``tiles`` (``test_tiles``: the report's held-out images scored with theirs too)."""
    report = compare_feature_sets(tables, settings["reg"], settings["subspace"], tiles, test_tiles=test_tiles)
    rows = [{"feature_set": r.feature_set, "correct": int(r.correct), "n": int(r.n)}
            for r in report[report["status"] == "ok"].itertuples() if keep(r.feature_set)]
    ok, joined, candidates = record_inputs(tables, tiles, settings["feature_set"])
    result = record_loocv(ok, candidates, joined, settings)
    return rows + [{"feature_set": "classifier of record", "correct": result.correct, "n": result.n}]


def two_mode_markdown(table: pd.DataFrame, modes: tuple[str, str], heading: str) -> str:
    """``heading``, then one line per run and feature set: images right in each of the two ``modes``."""
    wide = table.pivot_table(index=["run", "feature_set"], columns="mode", values="correct", sort=False).reset_index()
    n = table.groupby("run")["n"].max()
    lines = [heading, "", f"| run | feature set | {modes[0]} | {modes[1]} |", "|---|---|---|---|"]
    lines += [f"| `{r['run']}` | {r['feature_set']} | {int(r[modes[0]])}/{n[r['run']]} | {int(r[modes[1]])}/{n[r['run']]} |"
              for _, r in wide.iterrows()]
    return "\n".join(lines) + "\n"


def runs_report(doc: str, name: str, runs_help: str, rows_of_run: Callable[..., list[dict]],
                markdown: Callable[[pd.DataFrame], str], flags: tuple[tuple[str, str], ...] = ()) -> None:
    """The command line ``RUN [RUN ...] [--out DIR] [--name NAME]`` of a per-run benchmark: ``rows_of_run`` of every
    run (a path under the repository root) in one table, published with its ``markdown`` (:func:`publish`).

    Each of ``flags`` (``--flag-name``, help) adds a switch, passed to ``rows_of_run`` as a keyword (``flag_name``).
    """
    parser = argparse.ArgumentParser(description=doc.splitlines()[0])
    parser.add_argument("runs", nargs="+", help=runs_help)
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "bench")
    parser.add_argument("--name", default=name)
    for flag, text in flags:
        parser.add_argument(flag, action="store_true", help=text)
    args = parser.parse_args()
    switches = {flag.lstrip("-").replace("-", "_") for flag, _ in flags}
    options = {key: value for key, value in vars(args).items() if key in switches}
    table = pd.DataFrame([row for run in args.runs for row in rows_of_run(ROOT / run, **options)])
    publish(args.out, args.name, table, markdown(table))


def seed_prepared(results: Path, image: str | None = None) -> None:
    """Copy prepared images (one, or all) from the main results folder into ``results`` where missing."""
    source = ROOT / "results" / "prepared"
    if image is not None:
        source, results = source / image, results / "prepared"
    target = results / source.name
    if source.exists() and not target.exists():
        shutil.copytree(source, target)


def fresh_run(results: Path, images: list[str] | None) -> Path:
    """Empty ``results`` (fits of older code would pass for current under mtime triggers), seed it with the main
    run's prepared photos and write its sample sheet of ``images`` (None: every image); returns the sheet."""
    shutil.rmtree(results, ignore_errors=True)
    results.mkdir(parents=True)
    seed_prepared(results)
    return write_sheet(images, results / "samples.tsv")


def snakemake(args: list[str], cores: int = 2, home: str | None = None, capture: bool = False,
              root: Path = ROOT) -> float:
    """Run ``snakemake --cores <cores> <args>`` in the repository (or in ``root``, a copy of it at another commit,
    whose ``src`` then comes first on the import path); returns its wall time in seconds."""
    env = dict(os.environ)
    if home:
        env["HOME"] = home
    if root != ROOT:
        env["PYTHONPATH"] = os.pathsep.join([str(root / "src"), *filter(None, [env.get("PYTHONPATH")])])
    started = time.perf_counter()
    subprocess.run([sys.executable, "-m", "snakemake", "--cores", str(cores), *args], cwd=root, env=env, check=True,
                   capture_output=capture)
    return time.perf_counter() - started


def code_at(commit: str, folder: Path) -> Path:
    """The repository's tracked files at ``commit``, unpacked once into ``folder / <full sha>``; returns that copy."""
    sha = subprocess.run(["git", "rev-parse", "--verify", f"{commit}^{{commit}}"], cwd=ROOT, capture_output=True,
                         text=True)
    if sha.returncode != 0:
        raise SystemExit(f"{Path(sys.argv[0]).stem}: error: no commit {commit!r} in this repository")
    full = sha.stdout.strip()
    copy = folder / full
    if not copy.is_dir():
        partial = copy.with_name(full + ".partial")
        shutil.rmtree(partial, ignore_errors=True)
        partial.mkdir(parents=True)
        archive = subprocess.run(["git", "archive", full], cwd=ROOT, capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", str(partial)], input=archive.stdout, check=True)
        partial.rename(copy)
    return copy


def stage_benchmarks(results: Path, image: str) -> dict[str, tuple[float, float]]:
    """(seconds, peak RSS MB) of each fit stage of ``image`` from the rules' ``benchmark:`` files; NaN for a stage
    without one (it did not finish)."""
    paths = {stage: results / "benchmarks" / f"fit_{stage}" / f"{image}.tsv" for stage in STAGES}
    return {stage: benchmark_seconds(path) or (float("nan"), float("nan")) for stage, path in paths.items()}


def fit_costs(results: Path, image: str) -> dict[str, float]:
    """Each fit stage's seconds and peak RSS MB of ``image`` (``<stage>_s``, ``<stage>_max_rss_mb``; NaN for a stage
    that did not finish), their sum ``fit_s`` (NaN unless every stage finished) and the largest ``max_rss_mb``."""
    row: dict[str, float] = {}
    for stage, (seconds, rss) in stage_benchmarks(results, image).items():
        row[f"{stage}_s"], row[f"{stage}_max_rss_mb"] = seconds, rss
    row["fit_s"] = sum(row[f"{stage}_s"] for stage in STAGES)
    row["max_rss_mb"] = float(pd.Series([row[f"{stage}_max_rss_mb"] for stage in STAGES]).max())
    return row
