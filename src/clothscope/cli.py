"""Command line: ``clothscope sheet`` and ``clothscope synthesize``.

Errors are printed as one line (``clothscope: error: ...``) with exit code 2.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from .atomic import write_text
import pandas as pd

from .samples import COLUMNS, sheet_from_folder, sheet_to_tsv
from .schema import InputError


def cmd_sheet(args: argparse.Namespace) -> None:
    """Print (or write) a sample sheet built from a folder tree <root>/<class>/<image>."""
    text = sheet_to_tsv(sheet_from_folder(args.root, source=args.source))
    if args.output:
        write_text(args.output, text)
    else:
        sys.stdout.write(text)


def cmd_synthesize(args: argparse.Namespace) -> None:
    """Regenerate the synthetic dataset (all of it, or the ids given) into a folder."""
    from .synth.generate import dataset_index, save, synthesize

    wanted = set(args.ids or [])
    out = Path(args.out)
    started = time.perf_counter()
    rows = []
    for fabric, dye_index, image_id in dataset_index(args.colors_per_class):
        path = out / fabric / f"{image_id}.png"
        rows.append({"image_id": image_id, "path": str(path), "fabric_class": fabric,
                     "dye_color": image_id.removeprefix(f"{fabric}_"), "source": f"synthetic seed={args.seed}"})
        if wanted and image_id not in wanted:
            continue
        image = synthesize(fabric, dye_index, args.seed, args.resolution, args.spp, args.mesh_resolution, args.variant, args.threads)
        save(image, path)
        print(f"{image_id}\t{image.truth['provenance']['render_seconds']:.2f} s", flush=True)
    if args.sheet:
        write_text(args.sheet, sheet_to_tsv(pd.DataFrame(rows, columns=COLUMNS)))
    print(f"total\t{time.perf_counter() - started:.1f} s")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="clothscope", description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    sheet = commands.add_parser("sheet", help="build a sample sheet from <root>/<class>/<image>")
    sheet.add_argument("root", help="folder whose sub-folders are fabric classes")
    sheet.add_argument("-o", "--output", help="write the TSV here instead of standard output")
    sheet.add_argument("--source", default="", help="value of the 'source' column")
    sheet.set_defaults(func=cmd_sheet)
    synth = commands.add_parser("synthesize", help="render the synthetic dataset with ground truth")
    synth.add_argument("--out", default="data/synthetic", help="output folder (default: data/synthetic)")
    synth.add_argument("--seed", type=int, default=20261121)
    synth.add_argument("--resolution", type=int, default=256)
    synth.add_argument("--spp", type=int, default=64)
    synth.add_argument("--mesh-resolution", type=int, default=768)
    synth.add_argument("--colors-per-class", type=int, default=6)
    synth.add_argument("--variant", default="auto")
    synth.add_argument("--threads", type=int, default=None)
    synth.add_argument("--sheet", help="also write the sample sheet of the generated set here")
    synth.add_argument("ids", nargs="*", help="only these image ids")
    synth.set_defaults(func=cmd_synthesize)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        args.func(args)
    except (InputError, ValueError, OSError) as err:
        print(f"clothscope: error: {err}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
