"""Benchmark: fit time per image of fit settings side by side, in alternating rounds on one machine.

Each variant is a preset plus an overlay of knobs. Every round fits the same
images from their prepared photos through the real workflow (all three stages,
two images side by side on two cores, one Dr.Jit thread each, as the default
profile runs them), into an emptied folder per variant; the variants' order
reverses every round, so a drift in the machine's speed falls on all of them
alike. Seconds and peak memory come from the rules' ``benchmark:`` files.

The prepared photos are copied from the main run unless ``--prepare`` is given
or ``--sheet`` names another sample sheet (the main run's prepared photos are
those of ``config/samples.tsv``): then every round also prepares the photos from
the files the sheet names (a field set's 1024-2048 px photos, for example), and
the table adds the prepare job's seconds and memory, the photo's native size and
``image_s`` (prepare and fit).

A variant ``at:<commit>`` is the default preset with the code of another commit (its tracked files unpacked under
``<out>/code``, its own Snakefile, schema and package), so the time of today's code and of an older one are
measured as a ratio on the same machine in the same hour; with such a variant every variant prepares its photos
with its own code.

    .venv/bin/python workflow/benchmarks/fit_speed.py [--variants default,lean,fast,seed_cycle,at:<commit>] [--images ...]
        [--rounds 2] [--sheet config/samples.tsv] [--prepare]

Writes ``<out>/fit_speed.csv`` (one row per image, variant and round) and
``<out>/fit_speed.md`` (medians per variant and each variant's time as a
fraction of the first one's).
"""
from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

import pandas as pd
import yaml
from harness import ROOT, STAGES, TWO_PER_CLASS, code_at, fit_costs, publish, seed_prepared, shown, snakemake, write_sheet

from clothscope.evaluate.accuracy import benchmark_seconds

#: variant -> (preset, overlay of knobs)
VARIANTS: dict[str, tuple[str, dict]] = {
    "default": ("default", {}),
    # fewer material and joint steps, a 1-sample gradient pass: rejected on a confirmation set (docs/design.md)
    "lean": ("default", yaml.safe_load((ROOT / "config" / "overlays" / "lean_fit.yaml").read_text())),
    "fast": ("fast", {}),
    # the normal-map stage cycles through 16 seeds and reuses their intersections (docs/design.md)
    "seed_cycle": ("default", yaml.safe_load((ROOT / "config" / "overlays" / "seed_cycle.yaml").read_text())),
    # fast with fewer geometry, material and joint steps (docs/design.md, "A lighter fast preset")
    "fast_lite": ("default", yaml.safe_load((ROOT / "config" / "overlays" / "fast_lite.yaml").read_text())),
}
#: prefix of a variant that fits with the default preset of another commit's code
AT = "at:"


def preset_and_overlay(name: str) -> tuple[str, dict]:
    """The preset and overlay of knobs of variant ``name`` (``at:<commit>``: the default preset, no overlay)."""
    return ("default", {}) if name.startswith(AT) else VARIANTS[name]


def prepare_costs(folder: Path, image: str) -> dict[str, float]:
    """The prepare job's seconds and peak RSS MB, and the photo's native long side."""
    seconds, rss = benchmark_seconds(folder / "benchmarks" / "prepare" / f"{image}.tsv") or (float("nan"), float("nan"))
    status = json.loads((folder / "prepared" / image / "status.json").read_text(encoding="utf-8"))
    native = max(status.get("source_size") or [float("nan")])  # older code may not record it
    return {"prepare_s": seconds, "prepare_max_rss_mb": rss, "native_px": native}


def with_paths_from_root(sheet: Path) -> None:
    """Rewrite the relative photo paths of ``sheet`` as absolute paths under the repository, for a run in another copy."""
    table = pd.read_csv(sheet, sep="\t", dtype=str, keep_default_na=False)
    table["path"] = [str(ROOT / path) for path in table["path"]]  # an absolute path stays as it is
    table.to_csv(sheet, sep="\t", index=False)


def fit_variant(name: str, images: list[str], folder: Path, source: Path, prepare: bool, root: Path = ROOT) -> pd.DataFrame:
    """Fit ``images`` of the sheet ``source`` with variant ``name`` and the code in ``root`` into the emptied
    ``folder`` (preparing the photos too with ``prepare``); one row of stage seconds and memory per image."""
    preset, overlay = preset_and_overlay(name)
    shutil.rmtree(folder, ignore_errors=True)
    folder.mkdir(parents=True)
    if not prepare:
        for image in images:
            seed_prepared(folder, image)
    (folder / "overlay.yaml").write_text(json.dumps(overlay))
    sheet = write_sheet(images, folder / "samples.tsv", source)
    if root != ROOT:
        with_paths_from_root(sheet)
    snakemake(["--configfile", "config/config.yaml", str(folder / "overlay.yaml"), "--quiet", "all", "--config",
               f"preset={preset}", f"samples={sheet}", f"results={folder}", "--",
               *[str(folder / "fit" / image / "normals") for image in images]], capture=True, root=root)
    rows = []
    for image in images:
        row = {"image_id": image, "variant": name} | fit_costs(folder, image)
        if prepare:
            row |= prepare_costs(folder, image)
            row["image_s"] = row["prepare_s"] + row["fit_s"]
            row["max_rss_mb"] = max(row["max_rss_mb"], row["prepare_max_rss_mb"])
        rows.append(row)
    return pd.DataFrame(rows)


def summary(table: pd.DataFrame, names: list[str], images: int, rounds: int, source: Path) -> str:
    """Markdown: medians per variant and each one's median fit time as a fraction of the first variant's."""
    timed = ["prepare_s"] if "prepare_s" in table else []
    timed += [f"{stage}_s" for stage in STAGES] + ["fit_s"] + (["image_s"] if "image_s" in table else [])
    medians = table.groupby("variant")[timed].median().reindex(names)
    medians["max_rss_mb"] = table.groupby("variant")["max_rss_mb"].max().reindex(names)
    medians[f"fit_s / {names[0]}"] = medians["fit_s"] / medians.loc[names[0], "fit_s"]
    overlays = [f"- `{name}`: the default preset with the code of commit `{name[len(AT):]}`" if name.startswith(AT) else
                f"- `{name}`: preset `{VARIANTS[name][0]}`, overlay `{json.dumps(VARIANTS[name][1])}`" for name in names]
    photos = (f"The photos are {int(table['native_px'].min())}-{int(table['native_px'].max())} px on their long side "
              "and were prepared in every round (`prepare_s`; `image_s` is prepare and fit; `max_rss_mb` is the "
              "largest of the four jobs'). " if table.get("native_px", pd.Series(dtype=float)).notna().any() else "")
    return "\n".join(["# Fit time per image, variants side by side", "",
                      f"{images} images of `{shown(source)}`, {rounds} rounds (the variants' order reversed every round); "
                      "all three fit stages through snakemake, two images side by side on two cores, one Dr.Jit thread "
                      f"each. {photos}Medians over images and rounds of the rules' `benchmark:` seconds.", "", *overlays, "",
                      medians.round(3).to_markdown(), ""])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", default=",".join(VARIANTS),
                        help=f"any of {', '.join(VARIANTS)} or {AT}<commit>; the first is the reference")
    parser.add_argument("--images", default=TWO_PER_CLASS)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--out", default="results/bench/fit_speed")
    parser.add_argument("--sheet", default="config/samples.tsv", help="sample sheet the images are read from")
    parser.add_argument("--prepare", action="store_true",
                        help="prepare the photos in every round instead of copying the main run's (always with another --sheet)")
    args = parser.parse_args()
    names, images = args.variants.split(","), args.images.split(",")
    unknown = sorted(name for name in set(names) - set(VARIANTS) if not name.startswith(AT))
    if unknown:
        raise SystemExit(f"fit_speed: error: unknown variant(s) {', '.join(unknown)}; choose from {', '.join(VARIANTS)}")
    if args.rounds < 1:
        raise SystemExit(f"fit_speed: error: --rounds must be at least 1, got {args.rounds}")
    out, source = (ROOT / args.out).resolve(), (ROOT / args.sheet).resolve()
    if not source.is_file():
        raise SystemExit(f"fit_speed: error: no sample sheet at {args.sheet}")
    roots = {name: code_at(name[len(AT):], out / "code") if name.startswith(AT) else ROOT for name in names}
    prepare = args.prepare or source != (ROOT / "config" / "samples.tsv").resolve() or any(r != ROOT for r in roots.values())
    tables = []
    for round_ in range(args.rounds):
        for name in names if round_ % 2 == 0 else names[::-1]:
            folder = out / "runs" / name.replace(":", "_")
            tables.append(fit_variant(name, images, folder, source, prepare, roots[name]).assign(round=round_))
            print(f"round {round_} {name}: median {tables[-1]['fit_s'].median():.2f} s per image", flush=True)
    table = pd.concat(tables, ignore_index=True)
    publish(out, "fit_speed", table, summary(table, names, len(images), args.rounds, source))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
