"""Benchmark set: real photos of cloth, split into a design half, a confirmation half and optional further sets.

The project's own sets are synthetic. This script builds sample sheets of real photos from a local copy of a
public collection of fabric photos labelled by material, ``github.com/biancajayy/FabricClassification`` at commit
``85eb65094e39682e7187e513072e4510372dc80d`` (folder ``Images/<Class>/``: cotton, denim, linen, polyester; product
and stock close-ups, 183-2667 px on the short side). The collection states no licence, so no photo is committed here:
clone it yourself and pass its ``Images`` folder.

Per class, in file-name order, exact duplicates (same bytes) and photos under ``--min-side`` px on the short side are
dropped; the rest are shuffled with one seeded generator (classes in name order) and the first ``--per-class`` go to
half ``a`` (design: settings may be chosen on it), the next ``--per-class`` to half ``b`` (confirmation: scored only
under a rule written beforehand), and so on for each name of ``--sets`` (``a b c`` adds a third set, ``c``; ``a`` and
``b`` stay the same). Each set's photos are copied to ``<out>/<set>/photos/<class>/`` and its sheet written to
``<out>/<set>/samples.tsv``; a set whose folder exists is left as it is. Run the workflow on a set with

    .venv/bin/snakemake --cores 2 --config samples=results/real/a/samples.tsv results=results/real/a/run

    .venv/bin/python workflow/benchmarks/real_photos.py --source <clone>/Images [--out results/real]
        [--sets a b] [--per-class 12] [--min-side 300] [--seed 20261207] [--last-short]
"""
from __future__ import annotations

import argparse
import hashlib
import random
import shutil
from pathlib import Path

from PIL import Image

from clothscope.core.atomic import atomic_dir
from clothscope.core.samples import is_sample_file, sheet_from_folder, sheet_to_tsv

HALVES = ("a", "b")  # the design and confirmation halves; --sets may name more


def usable_photos(folder: Path, min_side: int) -> list[Path]:
    """The photos of one class folder in name order, without exact duplicates and those under ``min_side`` px."""
    seen: set[str] = set()
    kept = []
    for photo in sorted(p for p in folder.iterdir() if is_sample_file(p)):
        digest = hashlib.md5(photo.read_bytes()).hexdigest()
        if digest in seen:
            continue
        seen.add(digest)
        with Image.open(photo) as image:
            if min(image.size) >= min_side:
                kept.append(photo)
    return kept


def split_sets(source: Path, per_class: int, min_side: int, seed: int,
               names: tuple[str, ...] = HALVES, last_short: bool = False) -> dict[str, dict[str, list[Path]]]:
    """Set -> class -> photos: each class's usable photos shuffled, the first ``per_class`` to ``names[0]``, the next
    ``per_class`` to ``names[1]``, and so on. ``last_short``: the last set takes what is left of a class that has too
    few photos for it (at least one), instead of an error; the earlier sets are the same either way."""
    rng = random.Random(seed)
    sets: dict[str, dict[str, list[Path]]] = {name: {} for name in names}
    for folder in sorted((p for p in source.iterdir() if p.is_dir()), key=lambda p: p.name.lower()):
        photos = usable_photos(folder, min_side)
        rng.shuffle(photos)
        if len(photos) < len(names) * per_class and not (last_short and len(photos) > (len(names) - 1) * per_class):
            raise ValueError(f"{folder}: {len(photos)} usable photos, fewer than the {len(names) * per_class} "
                             f"{len(names)} sets need")
        for index, name in enumerate(names):
            sets[name][folder.name.lower()] = photos[index * per_class : (index + 1) * per_class]
    if not sets[names[0]]:
        raise ValueError(f"{source}: no class folders")
    return sets


def write_set(photos: dict[str, list[Path]], folder: Path) -> Path:
    """Copy a set's photos to ``folder/photos/<class>/`` and write its sample sheet; return the sheet's path.

    The set is built in a temporary folder that replaces ``folder`` when complete, so an interrupted copy leaves no
    folder that a rerun (which keeps existing sets) would take for a whole set.
    """
    with atomic_dir(folder) as tmp:
        for fabric_class, files in photos.items():
            target = tmp / "photos" / fabric_class
            target.mkdir(parents=True)
            for photo in files:
                shutil.copy2(photo, target / photo.name)
        sheet = sheet_from_folder(tmp / "photos")
        sheet["path"] = [str(folder / Path(path).relative_to(tmp)) for path in sheet["path"]]
        (tmp / "samples.tsv").write_text(sheet_to_tsv(sheet), encoding="utf-8")
    return folder / "samples.tsv"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--source", type=Path, required=True, help="the collection's Images folder (<Class>/<photo>)")
    parser.add_argument("--out", type=Path, default=Path("results/real"))
    parser.add_argument("--sets", nargs="+", default=list(HALVES), help="names of the sets, in order (a b: the halves)")
    parser.add_argument("--per-class", type=int, default=12)
    parser.add_argument("--min-side", type=int, default=300)
    parser.add_argument("--seed", type=int, default=20261207)
    parser.add_argument("--last-short", action="store_true",
                        help="let the last set take what is left of a class with too few photos")
    args = parser.parse_args()
    if not args.source.is_dir():
        parser.error(f"{args.source}: not a folder")
    if len(set(args.sets)) != len(args.sets) or any(not name.isidentifier() for name in args.sets):
        parser.error(f"--sets: distinct plain names wanted, got {' '.join(args.sets)}")
    try:
        sets = split_sets(args.source, args.per_class, args.min_side, args.seed, tuple(args.sets), args.last_short)
    except ValueError as error:
        parser.error(str(error))
    for name, photos in sets.items():
        if (args.out / name).exists():
            print(f"{name}: {args.out / name} exists, left as it is")
            continue
        sheet = write_set(photos, args.out / name)
        print(f"{name}: {sum(len(files) for files in photos.values())} photos -> {sheet}")


if __name__ == "__main__":
    main()
